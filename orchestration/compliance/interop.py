"""One scenario, three co-simulation engines: the fmpy master of this project, ``fmpy.ssp.simulate_ssp``
and the Open Simulation Platform engine (libcosim, through ``libcosimpy``), the latter two loading the
SSP archive ``orchestration.compliance.ssp`` writes. docs/interop.md explains the measured differences.

Step semantics (T = 0.01 s, t_k = k T):

- master (Gauss-Seidel in feedthrough order): at t_k the controller reads y(t_k), r(t_k) and its torque
  is held by the plant over [t_k, t_{k+1}): tau_k = f(y_k, r_k).
- libcosim's fixed-step algorithm (Jacobi): every instance steps from the inputs it holds, then all
  outputs are transferred. Before the first step libcosim propagates values in initialization mode
  (once per instance) and after exitInitializationMode, so tau_0 = f(y_0, r_0) as in the master; from
  then on the torque the plant holds over [t_k, t_{k+1}) is the one read after the controller's step
  from t_{k-1}: computed from y_{k-1}, r_{k-1} -- one step of delay in the loop.
- fmpy.ssp.simulate_ssp (Jacobi, no initial propagation): every connector starts at 0, so over the
  first step the plant holds tau = 0 and the controller sees an all-zero measurement and reference;
  then the same one-step delay. It reports, at the row labelled t_k, the values after the step that
  ends at t_{k+1}, does not apply the SSD's parameter bindings (the archive's parameterised FMU
  copies carry the scenario's values as their own start values), and loops ``while time < stop_time`` with time summed step by step, so
  it may run one step past the stop time (3 s: 0.01 summed 300 times is 2.99999999999998).

``run_jacobi`` emulates both Jacobi variants with direct FMI calls; the tests check that each engine
matches its emulation, so the difference to the master is the loop delay and nothing else.

Run ``python -m orchestration.compliance.interop [SCENARIO] --stop-time S`` for the comparison table.
"""
from __future__ import annotations

import argparse
import gc
import shutil
import tempfile
import time as clock
from ctypes import POINTER, c_double, c_int, c_int64, c_size_t, c_uint32
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orchestration.run.scenario import Scenario

NANO = 10**9


@dataclass
class EngineRun:
    """Samples of every Real output of every instance: ``outputs[instance][name][k]`` at ``time[k]``."""

    engine: str
    time: np.ndarray
    outputs: dict[str, dict[str, np.ndarray]]
    wall_s: float = 0.0
    notes: list[str] = field(default_factory=list)

    def at(self, times: np.ndarray, instance: str, name: str) -> np.ndarray:
        """Values at the given grid times (matched to 1e-9 s); every time must be present."""
        index = np.searchsorted(self.time, times - 1e-9)
        if np.any(index >= len(self.time)) or np.any(np.abs(self.time[index] - times) > 1e-9):
            raise ValueError(f"{self.engine} has no sample at some of the requested times")
        return self.outputs[instance][name][index]


def run_master(scenario: Scenario, fmu_paths: dict[str, Path]) -> EngineRun:
    from orchestration.run.master import run

    result = run(scenario, fmu_paths)
    if result.failed:
        raise RuntimeError(f"master run failed: {result.error}")
    return EngineRun("fmpy master", result.time, result.outputs, result.wall_time_s)


def run_fmpy_ssp(ssp: Path, scenario: Scenario) -> EngineRun:
    """``fmpy.ssp.simulate_ssp``; its row labelled t_k holds the values at t_{k+1} and is stored so."""
    from fmpy.ssp.simulation import simulate_ssp

    started = clock.perf_counter()
    rows = simulate_ssp(str(ssp), stop_time=scenario.stop_time, step_size=scenario.step_size)
    wall = clock.perf_counter() - started
    notes = ["no sample at t_0; row k holds t_{k+1}"]
    if len(rows) > scenario.steps:  # ``while time < stop_time`` with time accumulated: 0.01 summed 300
        notes.append(f"ran {len(rows) - scenario.steps} step(s) past stop_time (accumulated time fell short)")
        rows = rows[:scenario.steps]
    times = (np.arange(len(rows)) + 1) * scenario.step_size
    outputs: dict[str, dict[str, np.ndarray]] = {}
    for column in rows.dtype.names[1:]:
        instance, name = column.split(".", 1)
        outputs.setdefault(instance, {})[name] = np.asarray(rows[column], dtype=float)
    return EngineRun("fmpy.ssp", times, outputs, wall, notes)


def run_libcosim(ssp: Path, scenario: Scenario) -> EngineRun:
    """libcosim's fixed-step algorithm on the SSP, every Real output observed with a time series."""
    from libcosimpy._internal import get_last_error_message, libcosimc, wrap_function
    from libcosimpy.CosimEnums import CosimVariableCausality, CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    steps = scenario.steps
    execution = CosimExecution.from_ssp_file(str(ssp), step_size=int(round(scenario.step_size * NANO)))
    observer = CosimObserver.create_time_series(buffer_size=steps + 1)  # the default keeps 10000 samples
    execution.add_observer(observer)
    observed: dict[str, list[tuple[str, int, int]]] = {}
    for info in execution.slave_infos():
        instance, index = info.name.decode(), info.index
        for v in execution.slave_variables(index):
            if v.causality == CosimVariableCausality.OUTPUT.value and v.type == CosimVariableType.REAL.value:
                observer.start_time_series(index, v.reference, CosimVariableType.REAL)
                observed.setdefault(instance, []).append((v.name.decode(), index, v.reference))
    started = clock.perf_counter()
    if not execution.simulate_until(int(round(scenario.stop_time * NANO))):
        reason = get_last_error_message()
        del execution, observer
        gc.collect()
        raise RuntimeError(f"libcosim: the simulation failed: {reason}")
    wall = clock.perf_counter() - started
    n = steps + 1
    # libcosimpy's own reader drops samples whose step number is 0 (t_0 among them): read them directly
    read = wrap_function(lib=libcosimc(), funcname="cosim_observer_slave_get_real_samples",
                         argtypes=[POINTER(CosimObserver), c_int, c_uint32, c_int64, c_size_t,
                                   c_double * n, c_int64 * n, c_int64 * n], restype=c_int64)
    outputs: dict[str, dict[str, np.ndarray]] = {}
    times = None
    for instance, variables in observed.items():
        for name, index, reference in variables:
            values, step_numbers, time_points = (c_double * n)(), (c_int64 * n)(), (c_int64 * n)()
            got = read(observer.ptr(), index, reference, 0, n, values, step_numbers, time_points)
            if got != n:
                raise RuntimeError(f"libcosim returned {got} samples of {instance}.{name}, expected {n}")
            outputs.setdefault(instance, {})[name] = np.array(values[:], dtype=float)
            times = np.array(time_points[:], dtype=float) / NANO
    del execution, observer  # destroys the slaves (terminate, free) now, not at interpreter exit
    gc.collect()
    return EngineRun("libcosim", times, outputs, wall)


def run_jacobi(scenario: Scenario, fmu_paths: dict[str, Path], initial: str = "propagated",
               time_base: str = "nanoseconds") -> EngineRun:
    """The Jacobi schemes of the two SSP engines, with direct FMI calls (see the module docstring).

    ``initial="propagated"``: values propagated in initialization mode and after it (libcosim);
    ``initial="zero"``: every input starts at 0, nothing read before the first step (fmpy.ssp).
    ``time_base``: how communication points and steps are computed, "nanoseconds" (libcosim: integer
    nanoseconds, t_k = k 10^7 / 1e9 and h_k = t_{k+1} - t_k in double) or "accumulated" (fmpy.ssp:
    t += T, h = T).
    """
    from fmpy import read_model_description

    from orchestration.compliance.ssp import resolve_links
    from orchestration.run.fmi_direct import FmuInstance

    workdir = Path(tempfile.mkdtemp(prefix="sotc_jacobi_"))
    mds = {i.name: read_model_description(str(fmu_paths[i.fmu])) for i in scenario.instances.values()}
    links = resolve_links(scenario, mds)
    units: dict[str, FmuInstance] = {}
    T, n = scenario.step_size, scenario.steps
    started = clock.perf_counter()
    try:
        for inst in scenario.instances.values():
            units[inst.name] = FmuInstance(fmu_paths[inst.fmu], inst.name, workdir / inst.name)
        outputs = {name: u.names("output") for name, u in units.items()}
        inputs = {name: u.names("input") for name, u in units.items()}
        held = {name: {i: 0.0 for i in inputs[name]} for name in units}  # what each input connector holds

        def read_all() -> dict[str, dict[str, float]]:
            return {name: dict(zip(outputs[name], u.get(*outputs[name]))) for name, u in units.items()}

        def transfer(values: dict[str, dict[str, float]]) -> None:
            for link in links:
                held[link.target][link.input] = values[link.source][link.output]

        def push() -> None:
            for name, u in units.items():
                if held[name]:
                    u.set(**held[name])

        for inst in scenario.instances.values():
            u = units[inst.name]
            u.fmu.setupExperiment(startTime=0.0)
            u.set(**inst.parameters)
            u.fmu.enterInitializationMode()
        if initial == "propagated":
            for _ in range(len(units)):
                push()
                transfer(read_all())
        for u in units.values():
            u.fmu.exitInitializationMode()
        rows = []
        if initial == "propagated":
            push()
            values = read_all()
            rows.append(values)
            transfer(values)
        t, h, ns = 0.0, T, round(T * NANO)
        for k in range(n):
            if time_base == "nanoseconds":  # libcosim: integer ns, converted per point; h = t_{k+1} - t_k
                t = (k * ns) / NANO
                h = ((k + 1) * ns) / NANO - t
            push()
            for u in units.values():
                u.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            values = read_all()
            rows.append(values)
            transfer(values)
            if time_base == "accumulated":
                t += T
    finally:
        for u in units.values():
            u.free()
        shutil.rmtree(workdir, ignore_errors=True)
    first = 0 if initial == "propagated" else 1
    times = (np.arange(len(rows)) + first) * T
    result = {name: {o: np.array([row[name][o] for row in rows]) for o in outputs[name]} for name in units}
    return EngineRun(f"jacobi ({initial})", times, result, clock.perf_counter() - started)


def max_difference(a: EngineRun, b: EngineRun, instance: str, name: str) -> float:
    """Largest |a - b| of one output over the communication points both engines sampled."""
    common = np.intersect1d(np.round(a.time, 9), np.round(b.time, 9))
    return float(np.max(np.abs(a.at(common, instance, name) - b.at(common, instance, name))))


COMPARED = (("plant", "phi1"), ("plant", "phi2"), ("plant", "dphi1"), ("plant", "dphi2"),
            ("reference", "phi1_d"), ("controller", "tau1"), ("controller", "tau2"))


def comparison_table(runs: list[EngineRun], baseline: EngineRun) -> str:
    lines = [f"{'engine':<28}" + "".join(f"{i}.{n:<10}"[:18].ljust(19) for i, n in COMPARED) + "wall s"]
    for run in runs:
        cells = "".join(f"{max_difference(run, baseline, i, n):<19.3e}" for i, n in COMPARED)
        lines.append(f"{run.engine:<28}{cells}{run.wall_s:.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from orchestration.compliance.ssp import export_ssp
    from orchestration.fmu_build.build import ensure_built
    from orchestration.run.scenario import load_scenario

    parser = argparse.ArgumentParser(description="compare the fmpy master, fmpy.ssp and libcosim on a scenario")
    parser.add_argument("scenario", nargs="?", default="paper")
    parser.add_argument("--stop-time", type=float, default=10.0)
    parser.add_argument("--fmu-dir", type=Path, default=Path("build") / "fmus")
    args = parser.parse_args(argv)
    scenario = load_scenario(args.scenario).with_stop_time(args.stop_time)
    paths = ensure_built(sorted({i.fmu for i in scenario.instances.values()}), args.fmu_dir)
    with tempfile.TemporaryDirectory() as tmp:
        ssp = export_ssp(scenario, paths, Path(tmp) / f"{scenario.name}.ssp")
        master = run_master(scenario, paths)
        runs = [run_libcosim(ssp, scenario), run_jacobi(scenario, paths, "propagated", "nanoseconds"),
                run_fmpy_ssp(ssp, scenario), run_jacobi(scenario, paths, "zero", "accumulated")]
    print(f"{scenario.name}, {args.stop_time:g} s: max |engine - fmpy master| per output")
    print(comparison_table(runs, master))
    print("\nlibcosim vs its Jacobi emulation, fmpy.ssp vs its emulation:")
    print(comparison_table([runs[0]], runs[1]))
    print(comparison_table([runs[2]], runs[3]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
