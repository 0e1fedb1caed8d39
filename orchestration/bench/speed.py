"""``sotc-cosim bench`` (benchmark ``speed``): what a 100 s ``paper`` experiment costs, and how the
cost scales, measured side by side in one invocation (never in a test).

1. The floor: the same experiment as the in-process loop over the pure cores
   (``orchestration.study.pure_loop.simulate``: no FMI, no recording).
2. The same through the FMUs and the fmpy master, as ``sotc-cosim run`` does it (streamed, summary
   on the way), without and with the Rerun recording. 1-2 are alternated ``repeats`` times;
   medians, min and max are reported, with the ratios of the medians.
3. The cost per step of one recorded co-simulation, split: the cores (plant RK4 step, reference,
   controller evaluate and learn, timed inside the FMUs), the FMI plumbing (time inside fmpy's
   get/set/doStep calls minus those cores: ctypes, pythonfmu, the slave classes), the run's set-up
   (unpacking, instantiating and initialising the FMUs: once per run, spread over its steps), the
   master's own work (the rest of the run's time, the summary's included) and the recorder's own
   time (its start, blocks and finish, also given apart; the recording written by the writer
   process, as ``sotc-cosim run`` has it). Each figure is the median of ``repeats`` instrumented
   runs, without the timing wrappers' own cost (``instruments.wrapper_cost``), which is kept per row.
4. Long runs, each ``sotc-cosim run paper --stop-time S`` with recording in a fresh child process:
   wall time per simulated second against the same child run of 100 s, the peak RSS of the child
   (``ru_maxrss``: interpreter and libraries included) and the size of the recording.
5. Whole processes (``process``), one tuning trial (``trial``) and a trial of the benchmark's loop with a C
   controller FMU (``foreign``), each measured by its module.
"""
from __future__ import annotations

import contextlib
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from orchestration.bench.instruments import Timer, hosted_cores, patched, wrapper_cost
from orchestration.bench.process import process_walls
from orchestration.bench.targets import MASTER, PLUMBING, check_targets
from orchestration.bench import foreign
from orchestration.bench.trial import trial_costs, trial_line
from orchestration.fmu_build import compiled
from orchestration.markdown import table
from orchestration.progress import stage

SCENARIO = "paper"
LONG_RUNS = (1000.0, 10000.0)
# the split's row of what a run does once before its first step (the recorder's start excepted)
SET_UP = "run set-up: FMUs unpacked, instantiated, initialized (once per run)"



def machine() -> dict:
    model = "unknown"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    import fmpy
    import numpy

    return {"cpu": model, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": numpy.__version__, "fmpy": fmpy.__version__, "platform": platform.platform(),
            "load_average_at_start": list(os.getloadavg())}


def floor_core(scenario):
    """The controller core and plant settings of ``scenario`` for the pure loop (SOTC only)."""
    from fmu_controller.sotc import SotcCore

    if scenario.controller_fmu() != "SotcController":
        raise ValueError(f"the speed bench runs an SOTC scenario, {scenario.name} has {scenario.controller_fmu()}")
    ctrl = {k: float(v) for k, v in scenario.instances["controller"].parameters.items()}
    plant = scenario.instances["plant"].parameters
    start = dict(phi0=(plant.get("phi1_0", 0.5), plant.get("phi2_0", -0.5)),
                 dphi0=(plant.get("dphi1_0", 0.0), plant.get("dphi2_0", 0.0)))
    return (lambda: SotcCore(**ctrl)), start


def _stats(samples: list[float]) -> dict:
    return {"median": statistics.median(samples), "min": min(samples), "max": max(samples), "runs": samples}


def side_by_side(scenario, paths, repeats: int, compiled_paths=None) -> dict:
    """Floor, co-simulation and recorded co-simulation, alternated ``repeats`` times; with
    ``compiled_paths`` (the same FMUs with compiled cores) also their recorded co-simulation."""
    from orchestration.recording.writer import BLOCK_SIZE, RunRecorder
    from orchestration.run.master import run
    from orchestration.run.summary import SummaryObserver
    from orchestration.study.pure_loop import simulate

    make_core, start = floor_core(scenario)
    walls: dict[str, list[float]] = {"floor": [], "cosim": [], "cosim_recorded": []}
    variants = {"cosim_recorded": paths}
    if compiled_paths:
        walls["cosim_recorded_compiled"] = []
        variants["cosim_recorded_compiled"] = compiled_paths
    with tempfile.TemporaryDirectory(prefix="sotc_bench_") as tmp:
        for some in variants.values():
            with RunRecorder(Path(tmp) / "warm.rrd") as rec:  # imports, first blueprint, FMU extraction
                run(scenario.with_stop_time(1.0), some, observer=rec, keep_samples=False)
        for _ in range(repeats):
            t0 = time.perf_counter()
            simulate(make_core(), scenario.stop_time, scenario.step_size, **start)
            walls["floor"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            result = run(scenario, paths, observer=SummaryObserver(), keep_samples=False)
            walls["cosim"].append(time.perf_counter() - t0)
            _check(result)
            for key, some in variants.items():
                t0 = time.perf_counter()
                with RunRecorder(Path(tmp) / "run.rrd") as rec:
                    result = run(scenario, some, observer=[SummaryObserver(), rec], block_size=BLOCK_SIZE,
                                 keep_samples=False)
                walls[key].append(time.perf_counter() - t0)
                _check(result)
        rrd_bytes = (Path(tmp) / "run.rrd").stat().st_size
    runs = {k: _stats(v) for k, v in walls.items()}
    med = {k: v["median"] for k, v in runs.items()}
    return {"runs": runs, "rrd_mb": rrd_bytes / 1e6, "ratios": {
        "cosim_over_floor": med["cosim"] / med["floor"],
        "recorded_over_floor": med["cosim_recorded"] / med["floor"],
        "recording_overhead": med["cosim_recorded"] / med["cosim"],
    }}


def _check(result) -> None:
    if result.failed:
        raise RuntimeError(f"benchmark run failed: {result.error}")


def floor_cores(scenario) -> dict[str, float]:
    """Microseconds per step of the same cores in the floor's loop (an instrumented pure loop)."""
    from fmu_plant.trajectory import CircleTrajectory
    from orchestration.study import pure_loop

    make_core, start = floor_core(scenario)
    timer = Timer()
    core = make_core()
    core.evaluate = timer.wrap("controller evaluate", core.evaluate)
    core.advance = timer.wrap("controller learn", core.advance)
    with patched(pure_loop, "integrate", timer.wrap("plant step", pure_loop.integrate)), \
            patched(CircleTrajectory, "sample", timer.wrap("reference", CircleTrajectory.sample)):
        pure_loop.simulate(core, scenario.stop_time, scenario.step_size, **start)
    own = wrapper_cost()[1]
    return {label: (s - timer.calls[label] * own) * 1e6 / scenario.steps for label, s in timer.seconds.items()}


def cost_split(scenario, paths, writer=None, repeats: int = 1) -> dict:
    """Microseconds per step of each part of one recorded co-simulation step (see module doc), each
    figure the median of ``repeats`` runs; ``writer``: the ``WriterProcess`` that writes the recording,
    as ``sotc-cosim run`` has it written (else this process writes it)."""
    from orchestration.recording.writer import RunRecorder
    from orchestration.run import master

    with tempfile.TemporaryDirectory(prefix="sotc_bench_") as tmp:
        with RunRecorder(Path(tmp) / "warm.rrd") as warm:  # the FMUs' modules and what the recorder imports are loaded
            _check(master.run(scenario.with_stop_time(scenario.step_size), paths, observer=warm))
    split = _medians([_one_split(scenario, paths, writer) for _ in range(max(repeats, 1))])
    split["us_per_step"]["recording"] = sum(split["recording_parts_us_per_step"].values())  # its parts' medians
    split["total_us_per_step"] = sum(split["us_per_step"].values())  # the rows' medians, which it splits
    caller, own = wrapper_cost()
    split["wrapper_us_per_call"] = {"caller": caller * 1e6, "own": own * 1e6}
    split["floor_us_per_step"] = floor_cores(scenario)
    return split


def _one_split(scenario, paths, writer) -> dict:
    """One instrumented recorded run, split; each row without the timing wrappers' own cost
    (``instruments.wrapper_cost``: what each wrapped call adds to its caller's row and to its own)."""
    from orchestration.bench.design import _TimedRecorder
    from orchestration.recording.writer import BLOCK_SIZE
    from orchestration.recording.writer_process import recorder_for
    from orchestration.run import master
    from orchestration.run.summary import SummaryObserver

    cores, fmi, session = Timer(), Timer(), Timer()
    with tempfile.TemporaryDirectory(prefix="sotc_bench_") as tmp, hosted_cores(cores), _fmi_timed(fmi), \
            patched(master._Session, "load", session.wrap(SET_UP, master._Session.load)), \
            patched(master._Session, "finish", session.wrap("finish", master._Session.finish)):
        target = Path(tmp) / "split.rrd"
        recorder = _TimedRecorder(recorder_for(target, 1, writer))
        before = dict(writer.seconds) if writer is not None else {}
        with recorder.recorder:
            result = master.run(scenario, paths, observer=[SummaryObserver(), recorder], block_size=BLOCK_SIZE,
                                keep_samples=False)
    _check(result)
    per_step, (caller, own) = 1e6 / scenario.steps, wrapper_cost()
    core_calls, fmi_calls = sum(cores.calls.values()), sum(fmi.calls.values())
    fmi_s, cores_s = sum(fmi.seconds.values()), sum(cores.seconds.values())
    total_s = result.wall_time_s + session.seconds["finish"]  # the last block and the observers' finish follow the wall time
    set_up_s = session.seconds[SET_UP] - recorder.parts["start"]  # the recorder starts in the set-up: its own row
    split = {f"{label} (core, inside the FMU)": s * per_step for label, s in sorted(cores.seconds.items())}
    # what the wrappers add, per row: the cores' run inside the FMI calls, so their outer share lands in the plumbing
    removed = {f"{label} (core, inside the FMU)": cores.calls[label] * own for label in cores.seconds}
    removed[PLUMBING] = fmi_calls * own + core_calls * caller
    removed[MASTER] = fmi_calls * caller
    split[PLUMBING] = (fmi_s - cores_s) * per_step
    split[MASTER] = (total_s - fmi_s - set_up_s - recorder.seconds) * per_step
    split = {row: us - removed.get(row, 0.0) * per_step for row, us in split.items()}
    split[SET_UP] = set_up_s * per_step
    split["recording"] = recorder.seconds * per_step
    return {"us_per_step": split, "instrumented_us_per_step": total_s * per_step,
            "removed_us_per_step": {row: s * per_step for row, s in removed.items()},
            "instrumentation_us_per_step": sum(removed.values()) * per_step,
            "recording_parts_us_per_step": {k: v * per_step for k, v in recorder.parts.items()},
            "writer_us_per_step": None if writer is None else
            {k: (v - before.get(k, 0.0)) * per_step for k, v in writer.seconds.items()},
            "fmi_calls_us_per_step": {k: (v - fmi.calls[k] * own) * per_step for k, v in fmi.seconds.items()}}


def _medians(runs: list[dict]) -> dict:
    """Figure by figure (nested dicts alike), the median over ``runs`` of the same shape."""
    return {k: _medians([r[k] for r in runs]) if isinstance(v, dict) else
            None if v is None else statistics.median(r[k] for r in runs) for k, v in runs[0].items()}


def plumbing_floor(scenario, paths) -> dict:
    """Microseconds per step inside fmpy's get/set/doStep calls with empty FMUs of the same variables
    (``orchestration.bench.floor``): the floor of the plumbing figure of ``cost_split``."""
    from orchestration.bench.floor import empty_fmus
    from orchestration.run import master

    fmi, own = Timer(), wrapper_cost()[1]
    with tempfile.TemporaryDirectory(prefix="sotc_bench_floor_") as tmp, _fmi_timed(fmi):
        result = master.run(scenario, empty_fmus(paths, Path(tmp)), keep_samples=False)
    _check(result)
    per_call = {k: (v - fmi.calls[k] * own) * 1e6 / scenario.steps for k, v in fmi.seconds.items()}
    return {"fmi_calls_us_per_step": per_call, "us_per_step": sum(per_call.values())}


@contextlib.contextmanager
def _fmi_timed(timer: Timer):
    """The master's get, doStep and set calls timed under those labels."""
    from orchestration.run import master
    from orchestration.run.fmi2_instance import Instance2

    with patched(Instance2, "read_outputs", timer.wrap("get", Instance2.read_outputs)), \
            patched(Instance2, "do_step", timer.wrap("doStep", Instance2.do_step)), \
            patched(master._Inputs, "push", timer.wrap("set", master._Inputs.push)):
        yield


def child_run(stop_time: float, fmu_dir: Path, record: Path, record_every: int) -> dict:
    """One ``sotc-cosim run`` in a fresh interpreter; its wall time, peak RSS and recording size."""
    code = (
        "import json, resource, sys, time\n"
        "import orchestration.run.master, orchestration.recording.writer, orchestration.run.summary\n"
        "from orchestration.cli import main\n"
        "t0 = time.perf_counter()\n"
        "code = main(sys.argv[1:])\n"
        "wall = time.perf_counter() - t0\n"
        "print(json.dumps({'exit': code, 'wall_s': wall,"
        " 'peak_rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))\n"
    )
    argv = ["run", SCENARIO, "--stop-time", f"{stop_time:g}", "--fmu-dir", str(fmu_dir), "--recording", str(record),
            "--record-every", str(record_every)]
    proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"child run of {stop_time:g} s failed: {proc.stderr.strip()[-500:]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if out["exit"] != 0:
        raise RuntimeError(f"child run of {stop_time:g} s failed: {proc.stdout[-500:]}")
    size = record.stat().st_size
    record.unlink()
    return {"stop_time": stop_time, "wall_s": out["wall_s"], "wall_per_sim_s_ms": 1e3 * out["wall_s"] / stop_time,
            "peak_rss_mb": out["peak_rss_mb"], "rrd_mb": size / 1e6, "record_every": record_every}


def long_runs(fmu_dir: Path, stop_times, record_every: int) -> list[dict]:
    with tempfile.TemporaryDirectory(prefix="sotc_bench_long_") as tmp:
        base = child_run(100.0, fmu_dir, Path(tmp) / "base.rrd", record_every)
        runs = [base]
        for s in stop_times:
            r = child_run(float(s), fmu_dir, Path(tmp) / f"run{s:g}.rrd", record_every)
            r["vs_100s"] = r["wall_s"] / (base["wall_s"] * s / 100.0)  # 1.0: exactly linear
            runs.append(r)
    return runs


def bench_speed(fmu_dir: Path, repeats: int = 3, long: tuple[float, ...] = LONG_RUNS, record_every: int = 1,
                stop_time: float | None = None) -> dict:
    """Every measurement of the module doc; ``stop_time`` shortens the side-by-side runs (smoke tests)."""
    from orchestration.recording.writer_process import forked_writer

    with forked_writer() as writer:  # first, as ``run`` forks it: the split's recording is written by it
        return _bench_speed(fmu_dir, repeats, long, record_every, stop_time, writer)


def _bench_speed(fmu_dir: Path, repeats: int, long: tuple[float, ...], record_every: int,
                 stop_time: float | None, writer) -> dict:
    from orchestration.run.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    if stop_time is not None:
        scenario = scenario.with_stop_time(stop_time)
    models = sorted({i.fmu for i in scenario.instances.values()})
    paths = python_fmus(models, fmu_dir)
    fast = compiled_fmus(models, fmu_dir)
    data = {
        "benchmark": "speed", "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "method": {"scenario": SCENARIO, "stop_time": scenario.stop_time, "steps": scenario.steps,
                   "repeats": repeats, "statistic": "median (min-max) of alternated runs in one process",
                   "long_runs": "one run each in a fresh child process, with recording"},
    }
    data["compiled"] = compiled.target() if isinstance(fast, dict) else f"not measured: {fast}"
    stage("bench speed", f"{scenario.stop_time:g} s of {SCENARIO} side by side, {repeats} runs each")
    data.update(side_by_side(scenario, paths, repeats, fast if isinstance(fast, dict) else None))
    stage("bench speed", "the cost split per step, instrumented runs")
    data["split"] = cost_split(scenario, paths, writer, repeats)
    if isinstance(fast, dict):
        data["split_compiled"] = cost_split(scenario, fast, writer, repeats)
    stage("bench speed", "the plumbing's floor, then whole processes")
    data["plumbing_floor"] = plumbing_floor(scenario, paths)
    data["process"] = process_walls(next(iter((fast if isinstance(fast, dict) else paths).values())).parent, repeats)
    if stop_time is None:  # a shortened bench (a smoke test) leaves out the trials of 8 x 20 s (ours, a C FMU's)
        stage("bench speed", "a tuning trial's cost")
        trials = trial_costs(repeats)  # the compiled cores' trial is the one a tuning runs, when there is one
        data["trial"] = trials.pop("compiled", trials["default"])
        if trials["default"] is not data["trial"]:
            data["trial_default"] = trials["default"]
        stage("bench speed", "a trial of the benchmark's loop with a C controller FMU")
        data["foreign"] = foreign.foreign_row(repeats)
    if long:
        stage("bench speed", f"long runs of {', '.join(f'{s:g}' for s in long)} s, each in its own process")
    data["long"] = long_runs(fmu_dir, long, record_every) if long else []
    data["targets"] = check_targets(data)
    return data


def python_fmus(models: list[str], fmu_dir: Path) -> dict[str, Path]:
    """The FMUs with their cores in Python (``SOTC_COSIM_COMPILE=0``), built into ``fmu_dir/python``."""
    from orchestration.fmu_build.build import ensure_built

    with compiled.switched(False):
        return ensure_built(models, Path(fmu_dir) / "python")


def compiled_fmus(models: list[str], fmu_dir: Path) -> dict[str, Path] | str:
    """The same FMUs with compiled cores (``orchestration.fmu_build.compiled``): ``fmu_dir``'s own, the
    default build, unless compiling is switched off (then built into ``fmu_dir/compiled``); or why they
    cannot be built here."""
    from orchestration.fmu_build.build import ensure_built

    reason = compiled.unavailable()
    if reason:
        return reason
    where = Path(fmu_dir) if compiled.requested() else Path(fmu_dir) / "compiled"
    with compiled.switched(True):
        return ensure_built(models, where)


# --- reports ------------------------------------------------------------------------------------

def _runs_rows(data: dict) -> list[tuple[str, str, str]]:
    labels = {"floor": "floor: pure cores in-process (no FMI, no recording)",
              "cosim": "through the FMUs (fmpy master), no recording, cores in Python",
              "cosim_recorded": "through the FMUs, recorded (`sotc-cosim run paper`), cores in Python",
              "cosim_recorded_compiled": "the same, cores compiled (Cython)"}
    ref = data["runs"]["floor"]["median"]
    return [(labels[k], f"{v['median']:.3f} s ({v['min']:.3f}-{v['max']:.3f})", f"{v['median'] / ref:.2f}x")
            for k, v in data["runs"].items()]


def _best(data: dict, run: str, base: str) -> float:
    return data["runs"][run]["min"] / data["runs"][base]["min"]


def _split_rows(data: dict) -> list[list[str]]:
    split, total = data["split"]["us_per_step"], data["split"]["total_us_per_step"]
    floor = data["split"].get("floor_us_per_step", {})
    fast = data.get("split_compiled")
    rows = []
    for k, v in split.items():
        same = floor.get(k.replace(" (core, inside the FMU)", ""))
        rows.append([k, f"{v:.1f}", f"{v / total:.0%}", "" if same is None else f"{same:.1f}"]
                    + ([f"{fast['us_per_step'][k]:.1f}"] if fast else []))
    return rows + [["total", f"{total:.1f}", "100%", f"{sum(floor.values()):.1f}" if floor else ""]
                   + ([f"{fast['total_us_per_step']:.1f}"] if fast else [])]


def _long_rows(data: dict) -> list[list[str]]:
    rows = []
    for r in data["long"]:
        lin = f"{r['vs_100s']:.3f}" if "vs_100s" in r else "(base)"
        every = "" if r["record_every"] == 1 else f" (every {r['record_every']}th sample)"
        rows.append([f"{r['stop_time']:,.0f} s", f"{r['wall_s']:.1f} s", f"{r['wall_per_sim_s_ms']:.2f}", lin,
                     f"{r['peak_rss_mb']:.0f} MB", f"{r['rrd_mb']:.0f} MB{every}"])
    return rows


def format_markdown(data: dict) -> str:
    """The generated block of docs/performance.md (from the JSON of one bench run)."""
    m, meth = data["machine"], data["method"]
    lines = [
        f"Measured {data['date']} with `sotc-cosim bench` on {m['cpu']} ({m['cores']} cores; Python {m['python']}, "
        f"numpy {m['numpy']}, fmpy {m['fmpy']}; load average at start {m['load_average_at_start'][0]:.2f}). "
        f"`{meth['scenario']}`, {meth['stop_time']:g} s = {meth['steps']:,} steps; {meth['statistic']}, "
        f"{meth['repeats']} each.",
        "",
        table([f"{meth['stop_time']:g} s `paper`", "wall time", "vs floor"], _runs_rows(data)),
        "",
        f"Recording overhead {data['ratios']['recording_overhead']:.2f}x; the recording of these "
        f"{meth['stop_time']:g} s is {data['rrd_mb']:.1f} MB. The fastest runs (other load on a shared "
        f"machine only adds time) give {_best(data, 'cosim', 'floor'):.2f}x for the co-simulation and "
        f"{_best(data, 'cosim_recorded', 'floor'):.2f}x recorded against the floor, recording overhead "
        f"{_best(data, 'cosim_recorded', 'cosim'):.2f}x.",
        "",
        table(["per step (one recorded run, instrumented)", "us", "share", "the same core in the floor's loop, us"]
              + (["cores compiled, us"] if data.get("split_compiled") else []), _split_rows(data)),
        "",
        f"Compiled cores: {data.get('compiled', 'not measured (this measurement predates them)')}.",
    ]
    split = data.get("split_compiled") or data["split"]
    if "wrapper_us_per_call" in split:
        w = split["wrapper_us_per_call"]
        lines += ["", f"Each figure of the split is the median of {data['method']['repeats']} instrumented runs, "
                  "without the timing wrappers' own cost: measured in the same process on a method that does "
                  f"nothing, a wrapped call adds {w['caller']:.3f} us to its caller's row and {w['own']:.3f} us to "
                  f"its own, and {split['instrumentation_us_per_step']:.1f} us a step were taken out of each column's "
                  "rows (the same calls in both builds; `orchestration/bench/instruments.py`): "
                  + ", ".join(f"{row} {us:.2f}" for row, us in split["removed_us_per_step"].items())
                  + ". The target table gives the per-step figures with that cost as well."]
    parts = split.get("recording_parts_us_per_step")
    if parts:
        lines += ["", f"The recording's row, per step{' (cores compiled)' if data.get('split_compiled') else ''}: "
                  f"start {parts['start']:.1f} us (file, blueprint, properties; once per run), the blocks of "
                  f"samples {parts['block']:.1f}, finish {parts['finish']:.1f} (footer, file closed)."]
    if split.get("writer_us_per_step"):
        own = ", ".join(f"{k} {v:.1f}" for k, v in split["writer_us_per_step"].items())
        lines[-1] += (" As `sotc-cosim run` does, the recording was written by the writer process, which works "
                      "on its own core while the run goes on; the row is what the run waited for (handing each call "
                      f"over, and the answers it needs before the next block and at the end). The writer's own time, "
                      f"per step: {own}.")
    if "plumbing_floor" in data:
        f = data["plumbing_floor"]
        lines += ["", f"The plumbing's floor: the same master and instrumentation on empty pythonfmu FMUs with our "
                  f"variables (`orchestration/bench/floor.py`) spend {f['us_per_step']:.1f} us per step in "
                  f"get/set/doStep ({', '.join(f'{k} {v:.1f}' for k, v in f['fmi_calls_us_per_step'].items())}): "
                  "pythonfmu's C layer and fmpy's ctypes calls, which no change to our slaves removes."]
    if "process" in data:
        lines += ["", _process_line(data["process"], meth["repeats"])]
    if "trial" in data:
        lines += ["", trial_line(data["trial"])]
    if "trial_default" in data:
        lines += ["", trial_line(data["trial_default"], "The same trial with the cores the interpreter imports by "
                                                        "itself (in a source checkout the .py")]
    if "foreign" in data:
        lines += ["", foreign.line(data["foreign"])]
    if data["long"]:
        lines += ["", table(["single run, recorded (child process)", "wall time", "ms per simulated s",
                             "vs linear from 100 s", "peak RSS", "recording"], _long_rows(data))]
    lines += ["", table(["target", "met"], [[k, "yes" if ok else "**no**"] for k, ok in data["targets"].items()])]
    return "\n".join(lines)


def _process_line(p: dict, repeats: int) -> str:
    span = lambda k: f"{p[k]['median']:.2f} s ({p[k]['min']:.2f}-{p[k]['max']:.2f})"  # noqa: E731
    parts = [f"start-up, `sotc-cosim run paper --stop-time 0.01` recorded, {p['startup'].get('runs', repeats)} runs, "
             f"{span('startup')}"] if "startup" in p else []
    if "script" in p:
        parts.append(f"`sotc-cosim run paper` {span('run')} against the same experiment as a numpy user would write "
                     f"it (`benchmarks/plain_numpy.py`) {span('script')}, {repeats} each alternated: {p['ratio']:.2f}x")
    return f"Whole processes (fresh interpreters, median (min-max)): {'; '.join(parts)}."


def _figures(data: dict) -> dict[str, float]:
    out = {f"{k} median s": v["median"] for k, v in data["runs"].items()}
    out.update({k: v for k, v in data["ratios"].items()})
    out.update({f"{k} us/step": v for k, v in data["split"]["us_per_step"].items()})
    out.update({f"{r['stop_time']:g} s run wall s": r["wall_s"] for r in data["long"]})
    out.update({f"{r['stop_time']:g} s run peak RSS MB": r["peak_rss_mb"] for r in data["long"]})
    return out | foreign.figures(data.get("foreign", {}))


def compare(old: dict, new: dict) -> str:
    """Each figure both runs have: old, new and the change."""
    a, b = _figures(old), _figures(new)
    lines = [f"change since {old.get('date', '?')}:", f"{'figure':<48} {'old':>10} {'new':>10} {'change':>8}"]
    for key in (k for k in b if k in a):
        change = f"{b[key] / a[key] - 1.0:+.0%}" if a[key] else "-"
        lines.append(f"{key:<48} {a[key]:>10.4g} {b[key]:>10.4g} {change:>8}")
    return "\n".join(lines)


# the generated blocks (``orchestration.reports.docgen``) that show the stored measurement, per file
DOC_BLOCKS = {"speed": "docs/performance.md"}
MEASUREMENT = "docs/performance.json"


def stored_block(root: Path) -> str:
    """The tables of the stored measurement (``docs/performance.json``), as docgen renders them."""
    return format_markdown(json.loads((root / MEASUREMENT).read_text()))
