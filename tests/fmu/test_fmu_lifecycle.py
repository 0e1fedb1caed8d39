"""FMU lifecycle: independent instances, fmi2Reset, terminate/free orders, and calls made in the
wrong state, for every FMU in FMU_SOURCES.

Decisions (implemented in ``fmi_slave/slave.py``), per FMI 2.0 state:

| call                          | instantiated | initialization | stepping | terminated |
| ----------------------------- | ------------ | -------------- | -------- | ---------- |
| fmi2SetupExperiment           | OK           | refused        | refused  | refused    |
| fmi2EnterInitializationMode   | OK           | refused        | refused  | refused    |
| fmi2ExitInitializationMode    | refused      | OK             | refused  | refused    |
| fmi2DoStep                    | Discard      | Discard        | OK       | Discard    |
| fmi2GetReal                   | OK           | OK             | OK       | OK         |
| fmi2SetReal on an input       | OK           | OK             | OK       | OK         |
| fmi2SetReal, parameter change | OK           | OK             | refused  | refused    |
| fmi2SetReal on an output      | refused      | refused        | refused  | refused    |
| fmi2Terminate                 | OK           | OK             | OK       | OK         |

"refused": a non-OK status (pythonfmu can only say fmi2Fatal for these) with an Error message
naming the call or the variable, and the instance unchanged and usable afterwards.
Reset (pythonfmu re-creates the Python object) brings back every start value, parameters included.
"""
import math
import subprocess
import sys

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from support import child_env
from support.fmu_driver import DrivenFmu
from support.fmu_loop import drive, same_bits

from orchestration.fmu_build.build import FMU_SOURCES

T = 0.01
STATES = ("instantiated", "initialization", "stepping", "terminated")


class Subject:
    """A DrivenFmu with the modelDescription facts the tests need."""

    def __init__(self, fmu_file, workdir, name):
        self.unit = DrivenFmu(fmu_file, workdir, instance_name=name)
        md = self.unit.md
        self.inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.starts = {v.name: v.start for v in md.modelVariables if v.causality in ("parameter", "input")}
        self.types = {v.name: v.type for v in md.modelVariables}
        self.param, self.param_value = _changeable_parameter(md)

    def drive_inputs(self, k: int, scale: float = 1.0) -> None:
        if self.inputs:
            self.unit.set(**{n: scale * drive(n, i, k * T) for i, n in enumerate(self.inputs)})

    def run(self, k0: int, steps: int, scale: float = 1.0) -> list:
        rows = []
        for k in range(k0, k0 + steps):
            self.drive_inputs(k, scale)
            rows.append(self.unit.get(*self.outputs))
            self.unit.fmu.doStep(k * T, T)
        return rows

    def read_back(self) -> dict:
        values = {}
        for name in self.starts:
            vr = [self.unit.vr[name]]
            values[name] = (self.unit.fmu.getInteger(vr) if self.types[name] == "Integer" else self.unit.fmu.getReal(vr))[0]
        return values

    def bring_to(self, state: str) -> None:
        """From instantiated (after reset) to ``state``."""
        fmu = self.unit.fmu
        if state == "instantiated":
            return
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        if state == "initialization":
            return
        fmu.exitInitializationMode()
        self.drive_inputs(0)
        fmu.doStep(0.0, T)
        if state == "terminated":
            fmu.terminate()

    def free(self):
        self.unit.free()


def _changeable_parameter(md):
    """A Real parameter and a valid value different from its start (a small relative change)."""
    for v in md.modelVariables:
        if v.causality != "parameter" or v.type != "Real":
            continue
        start = float(v.start)
        value = start + 1e-3 * max(1.0, abs(start))
        if (v.min is None or float(v.min) < value) and (v.max is None or value < float(v.max)):
            return v.name, value
    raise AssertionError(f"{md.modelName}: no Real parameter can be changed a little")


@pytest.fixture
def subjects(fmu_paths, tmp_path):
    made = []

    def make(model, name="instance"):
        s = Subject(fmu_paths[model], tmp_path / f"{name}-{len(made)}", name)
        made.append(s)
        return s

    yield make
    for s in made:
        s.free()


def _same(a, b) -> bool:
    return same_bits(np.asarray(a, dtype=float), np.asarray(b, dtype=float))


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_two_instances_in_one_process_stay_independent(subjects, model):
    solo = subjects(model, "solo")
    solo.unit.initialize()
    solo_a = solo.run(0, 30, scale=1.0)
    solo.unit.fmu.reset()
    solo.unit.initialize(**{solo.param: solo.param_value})
    solo_b = solo.run(0, 20, scale=-0.5)

    a, b = subjects(model, "A"), subjects(model, "B")
    a.unit.initialize()
    first = a.run(0, 10, scale=1.0)
    b.unit.initialize(**{b.param: b.param_value})  # B starts later, with another parameter and inputs
    rows_a, rows_b = [], []
    for k in range(20):
        rows_a += a.run(10 + k, 1, scale=1.0)
        rows_b += b.run(k, 1, scale=-0.5)
    assert _same(first + rows_a, solo_a)
    assert _same(rows_b, solo_b)


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_reset_returns_every_start_value_and_replays_a_fresh_run(subjects, model):
    fresh = subjects(model, "fresh")
    fresh.unit.initialize()
    reference = fresh.run(0, 15)

    s = subjects(model, "reset")
    s.unit.set(**{s.param: s.param_value})
    s.unit.initialize()
    s.run(0, 7, scale=2.0)
    s.unit.fmu.reset()
    assert s.read_back() == {n: (int(v) if s.types[n] == "Integer" else float(v)) for n, v in s.starts.items()}
    s.unit.initialize()
    assert _same(s.run(0, 15), reference)


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_reset_after_a_refused_initialization_recovers(subjects, model):
    s = subjects(model)
    bad = next(v for v in s.unit.md.modelVariables if v.causality == "parameter" and v.type == "Real")
    s.unit.set(**{bad.name: math.nan})
    s.unit.fmu.setupExperiment(startTime=0.0)
    s.unit.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        s.unit.fmu.exitInitializationMode()
    assert f"'{bad.name}'" in s.unit.logged()
    s.unit.fmu.reset()
    s.unit.initialize()
    s.run(0, 3)


def _expect(outcome: str, call, unit, needle: str) -> None:
    unit.messages.clear()
    if outcome == "ok":
        call()
        return
    with pytest.raises(FMICallException) as info:
        call()
    status = info.value.status
    if outcome == "discard":
        assert status == 2, unit.logged()
    else:
        assert status >= 3, unit.logged()
    assert any(s >= 3 and needle in m for s, m in unit.messages), f"no Error naming {needle!r}: {unit.logged()}"


# expected outcome of each call in each state, in STATES order
MATRIX = {
    "setupExperiment": ("ok", "refused", "refused", "refused"),
    "enterInitializationMode": ("ok", "refused", "refused", "refused"),
    "exitInitializationMode": ("refused", "ok", "refused", "refused"),
    "doStep": ("discard", "discard", "ok", "discard"),
    "getReal": ("ok", "ok", "ok", "ok"),
    "setReal input": ("ok", "ok", "ok", "ok"),
    "setReal parameter": ("ok", "ok", "refused", "refused"),
    "setReal output": ("refused", "refused", "refused", "refused"),
    "terminate": ("ok", "ok", "ok", "ok"),
}


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_every_call_in_every_state_works_or_is_refused_with_a_reason(subjects, model):
    s = subjects(model)
    fmu = s.unit.fmu
    output = s.outputs[0]
    calls = {
        "setupExperiment": (lambda: fmu.setupExperiment(startTime=0.0), "fmi2SetupExperiment"),
        "enterInitializationMode": (fmu.enterInitializationMode, "fmi2EnterInitializationMode"),
        "exitInitializationMode": (fmu.exitInitializationMode, "fmi2ExitInitializationMode"),
        "doStep": (lambda: fmu.doStep(T if s._state in ("stepping", "terminated") else 0.0, T), "doStep"),
        "getReal": (lambda: s.unit.get(*s.outputs), ""),
        "setReal input": (lambda: s.inputs and s.unit.set(**{s.inputs[0]: 0.25}), ""),
        "setReal parameter": (lambda: s.unit.set(**{s.param: s.param_value}), f"'{s.param}'"),
        "setReal output": (lambda: fmu.setReal([s.unit.vr[output]], [1.0]), f"'{output}'"),
        "terminate": (fmu.terminate, ""),
    }
    for name, (call, needle) in calls.items():
        for state, outcome in zip(STATES, MATRIX[name]):
            fmu.reset()
            s.bring_to(state)
            s._state = state
            before = fmu.getFMUState()
            blob_before = fmu.serializeFMUState(before)
            fmu.freeFMUState(before)
            _expect(outcome, call, s.unit, needle)
            if outcome != "ok":  # refused: the instance is exactly as before and goes on working
                after = fmu.getFMUState()
                assert fmu.serializeFMUState(after) == blob_before, f"{name} in {state} changed the state"
                fmu.freeFMUState(after)
                if state in ("instantiated", "initialization"):
                    if state == "instantiated":
                        fmu.setupExperiment(startTime=0.0)
                        fmu.enterInitializationMode()
                    fmu.exitInitializationMode()
                    fmu.doStep(0.0, T)
                elif state == "stepping":
                    fmu.doStep(T, T)
            assert all(math.isfinite(y) for y in s.unit.get(*s.outputs)) or name == "setReal input"


def test_terminate_and_free_in_any_legal_order_leave_the_process_healthy(fmu_paths, tmp_path):
    """Run in a child process: a reference-count slip in the FMU binary shows only at interpreter exit."""
    paths = [str(fmu_paths[m]) for m in FMU_SOURCES]
    proc = subprocess.run([sys.executable, "-m", "support.lifecycle_child", str(tmp_path), *paths],
                          capture_output=True, text=True, timeout=300, env=child_env())
    assert proc.returncode == 0, f"exit code {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert proc.stdout.strip().endswith("all sequences ok"), proc.stdout + proc.stderr
