"""``sotc-cosim cross-check``: a reference run of every FMU in the FMI Cross-Check layout.

For each model the command writes, under ``OUT/fmus/<FMI version>/cs/<platform>/sotc-cosim/<version>/<Model>/``
(``2.0``, or ``3.0`` for the FMI 3.0 FMUs, whose arrays are written as their elements' FMI 2 names):

- ``<Model>.fmu``: the FMU;
- ``<Model>_in.csv``: its input signals (absent for an FMU without inputs);
- ``<Model>_ref.csv``: the reference result, time and every Real output;
- ``<Model>_ref.opt``: StartTime, StopTime, StepSize, RelTol;
- ``ReadMe.txt``: what the FMU is and how the files were made.

Inputs are realistic: the closed loop of the ``paper`` scenario is run first through the fmpy master
and each input takes the recorded signal of the same name (a controller gets the plant's measurement
and the reference it saw in the loop; the plant gets the loop's torques; an input no instance
provides, e.g. a disturbance, stays at its start value). The reference run then drives the FMU
alone, with the cross-check sampling convention every importer uses (``fmpy.simulate_fmu`` too):
inputs of t_0 are set in initialization mode and outputs recorded at t_0; then at each communication
point t_k the inputs of t_k are set, ``doStep(t_k, T)`` runs, and the outputs are recorded at t_{k+1}.
A controller's torque recorded at t_{k+1} is therefore computed from the inputs of t_k (it has direct
feedthrough), unlike in the closed loop, where the master reads it after setting the inputs of t_{k+1}.

Values are written with ``repr`` (shortest text that reads back to the same double).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fmi_slave import VERSION
from orchestration.outputs import atomic_file, atomic_write

TOOL = "sotc-cosim"
SOURCE_SCENARIO = "paper"
DEFAULT_STOP_TIME = 5.0
REL_TOL = 1e-6  # required by the layout; the FMUs step with a fixed-step integrator and ignore it


def platform() -> str:
    import fmpy

    return fmpy.platform


def model_dir(out_dir: Path, model: str, fmi_version: str = "2.0") -> Path:
    return Path(out_dir) / "fmus" / fmi_version / "cs" / platform() / TOOL / VERSION / model


def closed_loop_signals(fmu_paths: dict[str, Path], stop_time: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Every output of every instance of the source scenario's closed loop, by output name."""
    from orchestration.run.master import run
    from orchestration.run.scenario import load_scenario

    scenario = load_scenario(SOURCE_SCENARIO).with_stop_time(stop_time)
    result = run(scenario, fmu_paths)
    if result.failed:
        raise RuntimeError(f"the {scenario.name} loop that provides the inputs failed: {result.error}")
    signals: dict[str, np.ndarray] = {}
    for outputs in result.outputs.values():
        for name, values in outputs.items():
            signals.setdefault(name, values)
    return result.time, signals


def reference_run(fmu_file: Path, times: np.ndarray, inputs: dict[str, np.ndarray]) -> tuple[list[str], np.ndarray]:
    """Drive the FMU alone with ``inputs`` sampled at ``times``; returns output names and rows
    (time, outputs...) at every communication point, with the cross-check sampling convention."""
    from orchestration.run.fmi3_direct import open_instance

    instance = open_instance(fmu_file, Path(fmu_file).stem)
    try:
        outputs = instance.names("output")
        step = float(times[1] - times[0])
        row_inputs = lambda k: {n: float(v[k]) for n, v in inputs.items()}  # noqa: E731
        instance.initialize(start_time=float(times[0]), inputs=row_inputs(0))
        rows = [[times[0], *instance.get(*outputs)]]
        for k in range(len(times) - 1):
            instance.set(**row_inputs(k))
            instance.fmu.doStep(currentCommunicationPoint=float(times[k]), communicationStepSize=step)
            rows.append([times[k + 1], *instance.get(*outputs)])
        instance.fmu.terminate()
    finally:
        instance.free()
    return outputs, np.array(rows)


def write_csv(path: Path, names: list[str], rows: np.ndarray) -> None:
    with atomic_file(path) as f:
        f.write(",".join(f'"{n}"' for n in ["time", *names]) + "\n")
        for row in rows:
            f.write(",".join(repr(float(x)) for x in row) + "\n")


def _readme(model: str, description: str, has_inputs: bool, stop_time: float, step: float, fmi: str = "2.0") -> str:
    source = ("its inputs are the signals of the same name recorded in the closed loop of the "
              f"'{SOURCE_SCENARIO}' scenario (fmpy master), see {model}_in.csv" if has_inputs else "it has no inputs")
    return (
        f"{model}: {description}\n\n"
        f"Exported by {TOOL} {VERSION} with {'PythonFMU 0.7.0' if fmi == '2.0' else 'PythonFMU3 0.3.4'} "
        f"(an FMI {fmi} co-simulation FMU that runs its\n"
        "model in the host's Python interpreter: the importing process needs a CPython 3.11 with numpy,\n"
        "see docs/interop.md).\n\n"
        f"Reference: a fixed-step run of {stop_time:g} s with communication step {step:g} s; {source}.\n"
        "Inputs of t_k are set before doStep(t_k); outputs are recorded at every communication point.\n"
        f"Generated by `sotc-cosim cross-check`; checked by re-simulating with fmpy.simulate_fmu.\n"
    )


def generate(out_dir: Path, fmu_paths: dict[str, Path], stop_time: float = DEFAULT_STOP_TIME,
             models: list[str] | None = None) -> list[Path]:
    """Write the cross-check files of ``models`` (default: every FMU in ``fmu_paths``, which must also
    hold the FMUs of the source scenario); returns the model folders."""
    from orchestration.run.fmi3_direct import open_instance

    times, signals = closed_loop_signals(fmu_paths, stop_time)
    step = float(times[1] - times[0])
    folders = []
    for model in models or list(fmu_paths):
        fmu_file = fmu_paths[model]
        probe = open_instance(fmu_file, model)
        input_vars = [probe.vars[n] for n in probe.names("input")]
        description, fmi = probe.md.description or model, probe.md.fmiVersion
        probe.free()
        inputs = {v.name: signals[v.name] if v.name in signals else np.full(len(times), float(v.start or 0.0))
                  for v in input_vars}
        names, rows = reference_run(fmu_file, times, inputs)
        folder = model_dir(out_dir, model, fmi)
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write(folder / f"{model}.fmu", Path(fmu_file).read_bytes())
        if inputs:
            write_csv(folder / f"{model}_in.csv", list(inputs), np.column_stack([times, *inputs.values()]))
        else:
            (folder / f"{model}_in.csv").unlink(missing_ok=True)
        write_csv(folder / f"{model}_ref.csv", names, rows)
        atomic_write(folder / f"{model}_ref.opt",
            f"StartTime, {float(times[0])!r}\nStopTime, {float(times[-1])!r}\nStepSize, {step!r}\nRelTol, {REL_TOL!r}\n")
        atomic_write(folder / "ReadMe.txt", _readme(model, description, bool(inputs), float(times[-1]), step, fmi))
        folders.append(folder)
    return folders
