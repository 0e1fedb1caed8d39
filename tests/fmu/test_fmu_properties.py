"""Property-based tests (hypothesis): random inputs, parameters and step sizes thrown at every FMU.

- finite inputs of physically plausible size: doStep OK, every output finite;
- any finite input, however large: every output read is finite or the read is refused naming the
  output; doStep is OK or Discard with a logged reason, never an error status; after a Discard the
  state is exactly what it was;
- a non-finite input: reading an output that depends on it is refused naming the output and the
  input (never a stale number, never NaN with status OK), doStep answers Discard naming the input,
  and the state before the call is kept (bitwise);
- a step size that is not a finite positive number: Discard naming the step size, state kept;
- one parameter set to a random value: inside its declared [min, max] the FMU initializes, or refuses
  with a message naming a parameter (open bounds and cross-constraints such as sigma < rho or a
  reachable circle are not expressible as min/max); outside the range or non-finite it is refused
  (status >= Error) with a logged message naming it.

One instance per FMU serves every example: a saved FMU state (or fmi2Reset for the parameter tests)
puts it back at the start of each example.
"""
from __future__ import annotations

import json
import math
import signal
from contextlib import contextmanager

import pytest
from fmpy.fmi1 import FMICallException
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from support.fmu_driver import DrivenFmu

from orchestration.fmu_build.build import FMU_SOURCES

T = 0.01
SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
# magnitudes a physically meaningful input of each unit stays within (test-side notion of "plausible")
PLAUSIBLE = {"rad": 3.5, "rad/s": 10.0, "rad/s2": 50.0, "N.m": 20.0}
NONFINITE = st.sampled_from([math.nan, math.inf, -math.inf])


class Probe:
    """One initialized instance of a model, a saved state to start every example from."""

    def __init__(self, fmu_file, workdir, model):
        self.unit = DrivenFmu(fmu_file, workdir, instance_name=model)
        md = self.unit.md
        self.inputs = [v for v in md.modelVariables if v.causality == "input"]
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.depends = {u.variable.name: {d.name for d in u.dependencies} for u in md.outputs}
        self.parameters = [v for v in md.modelVariables if v.causality == "parameter"]
        self.unit.initialize()
        self.unit.fmu.doStep(0.0, T)  # start from a state that has moved once
        self.t = T
        self.start_state = self.unit.fmu.getFMUState()

    def fresh(self):
        self.unit.fmu.setFMUState(self.start_state)
        self.unit.messages.clear()
        return self.unit

    def state_bytes(self) -> bytes:
        state = self.unit.fmu.getFMUState()
        blob = self.unit.fmu.serializeFMUState(state)
        self.unit.fmu.freeFMUState(state)
        return blob

    def close(self):
        self.unit.fmu.freeFMUState(self.start_state)
        self.unit.free()


@pytest.fixture(scope="module")
def probes(fmu_paths, tmp_path_factory):
    made: dict[str, Probe] = {}

    def get(model: str) -> Probe:
        if model not in made:
            made[model] = Probe(fmu_paths[model], tmp_path_factory.mktemp(model), model)
        return made[model]

    yield get
    for probe in made.values():
        probe.close()


def read_finite_or_refused(unit, names) -> list[float] | None:
    """Read ``names``: finite values, or a refused call (never a non-finite value with status OK)
    whose logged Error names the output that is not finite."""
    unit.messages.clear()
    try:
        values = unit.get(*names)
    except FMICallException:
        assert any(s >= 3 and any(f"output '{n}'" in m for n in names) for s, m in unit.messages), unit.logged()
        return None
    assert all(math.isfinite(y) for y in values), dict(zip(names, values))
    return values


def plausible(var):
    bound = PLAUSIBLE.get(var.unit, 1.0)
    low = max(-bound, float(var.min)) if var.min is not None else -bound
    high = min(bound, float(var.max)) if var.max is not None else bound
    return st.floats(low, high, allow_nan=False)


@pytest.mark.parametrize("model", list(FMU_SOURCES))
@SETTINGS
@given(data=st.data())
def test_plausible_inputs_step_ok_with_finite_outputs(probes, model, data):
    probe = probes(model)
    unit = probe.fresh()
    values = {v.name: data.draw(plausible(v), label=v.name) for v in probe.inputs}
    unit.set(**values)
    assert all(math.isfinite(y) for y in unit.get(*probe.outputs)), unit.logged()
    unit.fmu.doStep(probe.t, T)
    assert all(math.isfinite(y) for y in unit.get(*probe.outputs)), unit.logged()


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy overflow inside a core, for absurd inputs
@pytest.mark.parametrize("model", list(FMU_SOURCES))
@SETTINGS
@given(data=st.data())
def test_any_finite_input_is_ok_or_discarded_with_a_reason(probes, model, data):
    probe = probes(model)
    if not probe.inputs:
        return
    unit = probe.fresh()
    values = {v.name: data.draw(st.floats(allow_nan=False, allow_infinity=False, width=64), label=v.name)
              for v in probe.inputs}
    unit.set(**values)
    read_finite_or_refused(unit, probe.outputs)
    before = probe.state_bytes()
    try:
        unit.fmu.doStep(probe.t, T)
    except FMICallException as exc:
        assert exc.status == 2, unit.logged()  # Discard, never Error/Fatal
        assert any(s >= 2 for s, _ in unit.messages), "a Discard without a logged reason"
        assert probe.state_bytes() == before, "a refused step changed the state"


@pytest.mark.parametrize("model", list(FMU_SOURCES))
@SETTINGS
@given(data=st.data())
def test_nonfinite_input_is_discarded_by_name_and_state_kept(probes, model, data):
    probe = probes(model)
    if not probe.inputs:
        return
    unit = probe.fresh()
    good = {v.name: data.draw(plausible(v), label=v.name) for v in probe.inputs}
    unit.set(**good)
    ok_state = unit.fmu.getFMUState()
    bad = data.draw(st.sampled_from(probe.inputs), label="bad input").name
    unit.set(**{bad: data.draw(NONFINITE, label="value")})
    for name in probe.outputs:  # an output computed from the bad input is refused, never returned
        if bad in probe.depends[name]:
            unit.messages.clear()
            with pytest.raises(FMICallException):
                unit.get(name)
            assert any(s >= 3 and f"'{name}'" in m and f"'{bad}'" in m for s, m in unit.messages), unit.logged()
        else:
            assert math.isfinite(unit.get(name)[0])
    with pytest.raises(FMICallException) as info:
        unit.fmu.doStep(probe.t, T)
    assert info.value.status == 2
    assert any(s >= 2 and f"'{bad}'" in m for s, m in unit.messages), unit.logged()
    # the refused step changed nothing: with the good value back, the step equals one from the saved state
    unit.set(**{bad: good[bad]})
    unit.fmu.doStep(probe.t, T)
    after_refusal = unit.get(*probe.outputs)
    unit.fmu.setFMUState(ok_state)
    unit.fmu.freeFMUState(ok_state)
    unit.fmu.doStep(probe.t, T)
    assert unit.get(*probe.outputs) == after_refusal


@pytest.mark.parametrize("model", list(FMU_SOURCES))
@SETTINGS
@given(step=st.one_of(st.floats(max_value=0.0), NONFINITE))
def test_bad_step_size_is_discarded_and_state_kept(probes, model, step):
    probe = probes(model)
    unit = probe.fresh()
    before = probe.state_bytes()
    with pytest.raises(FMICallException) as info:
        unit.fmu.doStep(probe.t, step)
    assert info.value.status == 2
    assert "step size" in unit.logged()
    assert probe.state_bytes() == before


def _parameter_value(var, data, inside: bool):
    low = None if var.min is None else float(var.min)
    high = None if var.max is None else float(var.max)
    integer = var.type == "Integer"
    if inside:
        if integer:
            return data.draw(st.integers(int(low), int(high)), label=var.name)
        return data.draw(st.floats(low, high, allow_nan=False, allow_infinity=False), label=var.name)
    choices = []
    if low is not None:
        choices.append(st.integers(-10**6, int(low) - 1) if integer else st.floats(max_value=low, exclude_max=True,
                                                                                     allow_infinity=False))
    if high is not None:
        choices.append(st.integers(int(high) + 1, 10**6) if integer else st.floats(min_value=high, exclude_min=True,
                                                                                     allow_infinity=False))
    if not integer:
        choices.append(st.just(math.nan))
        if low is not None:
            choices.append(st.just(-math.inf))
        if high is not None:
            choices.append(st.just(math.inf))
    return data.draw(st.one_of(choices), label=var.name) if choices else None


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # scipy, for absurd (refused) LQR weights
@pytest.mark.parametrize("model", list(FMU_SOURCES))
@SETTINGS
@given(data=st.data())
def test_random_parameter_is_accepted_or_refused_by_name(probes, model, data):
    probe = probes(model)
    unit = probe.unit
    unit.fmu.reset()  # back to instantiated, every variable at its start value
    unit.messages.clear()
    var = data.draw(st.sampled_from(probe.parameters), label="parameter")
    inside = data.draw(st.booleans(), label="inside the range")
    value = _parameter_value(var, data, inside)
    if value is None:  # a parameter any real value may take: no outside
        value, inside = _parameter_value(var, data, True) if var.min is not None else 0.0, True
    unit.set(**{var.name: value})
    unit.fmu.setupExperiment(startTime=0.0)
    unit.fmu.enterInitializationMode()
    try:
        unit.fmu.exitInitializationMode()
        refused = None
    except FMICallException as exc:
        refused = exc
    named = any(s >= 3 and f"'{var.name}'" in m for s, m in unit.messages)
    if not inside:
        assert refused is not None and refused.status >= 3, f"{var.name} = {value} was accepted"
        assert named, unit.logged()
    elif refused is not None:  # a cross-constraint (e.g. the circle must stay reachable) names its parameter
        names = {p.name for p in probe.parameters}
        assert any(s >= 3 and any(f"'{n}'" in m for n in names) for s, m in unit.messages), unit.logged()
    # leave the instance as the other tests expect it: initialized at the defaults, one step done
    unit.fmu.reset()
    unit.initialize()
    unit.fmu.doStep(0.0, T)


# --- the full declared parameter box, corners included ------------------------------------------------

class TimeLimit(Exception):
    """Raised by ``time_limit`` inside whatever runs too long (an FMU callback turns it into a failed call)."""


@contextmanager
def time_limit(seconds: float):
    """Fail the example if its body runs longer than ``seconds`` (a hang is a failure, not a stuck suite).
    ``fired`` tells even when an FMU callback caught the exception and answered with a status."""
    state = {"fired": False}

    def alarm(signum, frame):
        state["fired"] = True
        raise TimeLimit(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield state
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert not state["fired"], f"no answer within {seconds} s"


EXAMPLE_SECONDS = 10.0  # generous: a hang runs for minutes; a normal example takes milliseconds
# time-limited examples are not shrunk: shrinking a hang would cost EXAMPLE_SECONDS per attempt
BOUNDED = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow],
                   phases=[Phase.explicit, Phase.reuse, Phase.generate])


def _corners(var) -> list[float]:
    """The corners of one declared range: each finite bound (the nearest value inside an open one,
    i.e. one described as 'valid range (' ...), or +-1e308 where the range is unbounded."""
    if var.type == "Integer":
        return [int(var.min), int(var.max)]
    text = var.description or ""
    low_open = "valid range (" in text
    high_open = text.rstrip().endswith(")")
    low = -1e308 if var.min is None else float(var.min)
    high = 1e308 if var.max is None else float(var.max)
    return [math.nextafter(low, math.inf) if low_open else low, math.nextafter(high, -math.inf) if high_open else high]


def _box_value(var, data):
    kind = data.draw(st.sampled_from(["corner", "inside", "start"]), label=f"{var.name} kind")
    if kind == "corner":
        return data.draw(st.sampled_from(_corners(var)), label=var.name)
    if kind == "inside":
        low, high = _corners(var)
        if var.type == "Integer":
            return data.draw(st.integers(low, high), label=var.name)
        return data.draw(st.floats(low, high, allow_nan=False), label=var.name)
    return int(var.start) if var.type == "Integer" else float(var.start)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # scipy, for extreme (refused) LQR weights
@pytest.mark.parametrize("model", list(FMU_SOURCES))
@settings(BOUNDED, max_examples=25)
@given(data=st.data())
def test_parameter_box_corners_initialize_or_refuse_by_name_and_never_hang(probes, model, data):
    """Every parameter at a corner of its declared range, inside it, or at its start value, all at once:
    the FMU initializes or refuses naming a parameter, in bounded time; if it initializes, three steps
    with plausible inputs are OK or Discard with a reason, and no output is non-finite with status OK."""
    probe = probes(model)
    unit = probe.unit
    values = {v.name: _box_value(v, data) for v in probe.parameters}
    inputs = {v.name: data.draw(plausible(v), label=v.name) for v in probe.inputs}
    unit.fmu.reset()
    unit.messages.clear()
    try:
        with time_limit(EXAMPLE_SECONDS):
            unit.set(**values)
            unit.fmu.setupExperiment(startTime=0.0)
            unit.fmu.enterInitializationMode()
            try:
                unit.fmu.exitInitializationMode()
            except FMICallException as exc:
                assert exc.status >= 3
                names = {p.name for p in probe.parameters}
                assert any(s >= 3 and any(f"'{n}'" in m for n in names) for s, m in unit.messages), unit.logged()
                return
            for k in range(3):
                unit.set(**inputs)
                read_finite_or_refused(unit, probe.outputs)
                unit.messages.clear()
                try:
                    unit.fmu.doStep(k * T, T)
                except FMICallException as exc:
                    assert exc.status == 2 and any(s >= 2 for s, _ in unit.messages), unit.logged()
                    break
    finally:
        unit.fmu.reset()
        unit.initialize()
        unit.fmu.doStep(0.0, T)


# --- serialized states with a field perturbed -----------------------------------------------------------

HOSTILE = st.one_of(
    st.sampled_from([10**9, -5, 0, 2**63, -1, 1e308, -1e308, math.nan, math.inf, -math.inf, True, False,
                     None, "garbage", [], {}, [1, 2, 3], {"x": 1}, 0.5, "stepping"]),
    st.integers(-10**12, 10**12),
    st.floats(width=64),
)


def _leaves(tree, path=()):
    """Every (path, value) of a JSON tree, the containers themselves included."""
    yield path, tree
    if isinstance(tree, dict):
        for key, value in tree.items():
            yield from _leaves(value, path + (key,))
    elif isinstance(tree, list):
        for i, value in enumerate(tree[:12]):  # a long array: its first entries stand for the rest
            yield from _leaves(value, path + (i,))


def _replace(tree, path, value, delete: bool):
    if not path:
        return value
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    if delete and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return tree


class _Drawn:
    """An explicit example of a test drawing from ``st.data()``: each draw answers its label's value."""

    def __init__(self, **values):
        self.values = values

    def draw(self, strategy, label):
        return self.values[label]


@pytest.mark.parametrize("model", list(FMU_SOURCES))
@settings(BOUNDED, max_examples=40)
@given(data=st.data())
@example(data=_Drawn(field=("mode",), delete=False, value=[]))  # found: "unhashable type: 'list'", no field named
def test_perturbed_state_is_refused_by_field_or_runs_sanely(probes, model, data):
    """A serialized state with one field replaced (any type, any size) or deleted: fmi2SetFMUstate
    refuses it naming the field and changes nothing, or accepts it and the next steps end in bounded
    time with OK or Discard, never a non-finite output with OK."""
    probe = probes(model)
    unit = probe.fresh()
    blob = probe.state_bytes()
    state = json.loads(blob)
    paths = [p for p, _ in _leaves(state) if p]
    path = data.draw(st.sampled_from(paths), label="field")
    delete = data.draw(st.booleans(), label="delete") if isinstance(path[-1], str) else False
    value = data.draw(HOSTILE, label="value")
    hostile = json.dumps(_replace(json.loads(blob), path, value, delete)).encode()
    unit.messages.clear()
    with time_limit(EXAMPLE_SECONDS):
        loaded = unit.fmu.deSerializeFMUstate(hostile)
        try:
            unit.fmu.setFMUState(loaded)
            accepted = True
        except FMICallException:
            accepted = False
        unit.fmu.freeFMUState(loaded)
        if not accepted:
            named = str(path[1]) if path[0] == "values" and len(path) > 1 else str(path[0])
            # a parameter inside its range may break a cross-constraint, which names its parameter
            cross = path[0] == "values" and named in {p.name for p in probe.parameters}
            assert any(s >= 3 and (f"'{named}" in m or cross and "parameter '" in m) for s, m in unit.messages), \
                (path, unit.logged())
            assert probe.state_bytes() == blob, "a refused state changed the instance"
            return
        for _ in range(3):
            read_finite_or_refused(unit, probe.outputs)
            try:
                unit.fmu.doStep(json.loads(probe.state_bytes())["time"], T)
            except FMICallException as exc:
                assert exc.status == 2, unit.logged()
                break
