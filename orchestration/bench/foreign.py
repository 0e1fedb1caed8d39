"""One trial of the benchmark's loop with a controller FMU written in C (``sotc-cosim bench``, the ``foreign``
row; issue 49): what it costs per step in this process beyond the FMU's own doStep, and what running it in a
child process (``ForeignHost``: a crash or hang fails only its run) adds.

The FMU is ``examples/pd_controller``, built by its own script into a scratch folder, so the row needs a source
checkout and a C compiler: the installed wheel has no ``examples/`` folder (a C FMU is no build product of the
package, and the example is what users copy from the repository), and where either is missing the row says so
in one line instead of its figures. A trial is the tuning protocol's training set (``tuning.training_points``:
4 initial states, 4 perturbed points, ``tuning.STOP_TIME`` each) run back to back with the example's own gains
(``PARAMETERS``), the FMU loaded once and reset between the runs, ``pure_loop.metrics`` of each run computed
and no samples kept, as a trial reads them.

The measurement runs in a child interpreter whose cores are compiled where they can be (``trial.compiled_cores``,
as the tuning trial's row runs them; ``PYTHONPATH`` puts them first for the host's own child as well), and
measures ``repeats`` times, point by point in turn (a shared machine's speed changes within a second):

- the trial in-process (``ForeignLoop``): its wall time per step, set-up, resets and metrics included;
- the same trial through ``ForeignHost`` (its metrics checked against the in-process ones);
- fmpy's fmi2DoStep function on the in-process instance, alone in a Python loop of as many calls as a run has
  steps after each point (from the run's last time on): the FMU's own doStep per call, the ctypes call made as
  the loop makes it (``FMU._functions['fmi2DoStep']``, fmpy's declared argument types; the loop's iteration
  included).

Reported (median, min and max of the repeats): the trial per step, the doStep per call, their difference (the
trial's cost beyond the FMU's own doStep; target <= 10 us with compiled cores), hosted over in-process (target
<= 1.2), and how the FMU was loaded: ``ForeignLoop.reinstantiated`` (0: loaded once, reset between every run) and
the host's ``restarts``.
"""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from orchestration.bench.trial import compiled_cores
from orchestration.fmu_build import compiled
from orchestration.fmu_build.build import PACKAGE_ROOT
from orchestration.scratch import owner_prefix

EXAMPLE_BUILD = Path("examples") / "pd_controller" / "build.py"  # in a source checkout
FMU_NAME = "PdController.fmu"  # what EXAMPLE_BUILD writes
# the example's variables for each contract name it reads or writes (examples/README.md, docs/benchmark.md)
PORTS = {"phi1": "q1", "phi2": "q2", "dphi1": "dq1", "dphi2": "dq2", "phi1_d": "q1_ref", "phi2_d": "q2_ref",
         "dphi1_d": "dq1_ref", "dphi2_d": "dq2_ref", "tau1": "u1", "tau2": "u2"}
PARAMETERS = {"Kp": 60.0, "Kd": 15.0}  # the example's own gains, set as a trial sets its design
CHILD = ("import json, sys\n"
         "from orchestration.bench.foreign import measure\n"
         "print(json.dumps(measure(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]))))\n")


def example_build() -> Path | None:
    """The example's build script: in the checkout the package is imported from, else in the working folder (an
    installed package run from its source checkout, as CI runs the suite); None in neither."""
    found = [root / EXAMPLE_BUILD for root in (PACKAGE_ROOT, Path.cwd()) if (root / EXAMPLE_BUILD).is_file()]
    return found[0] if found else None


def foreign_row(repeats: int, stop_time: float | None = None) -> dict:
    """The row's figures (module docstring), measured in a child interpreter, its cores compiled unless they cannot
    be or ``SOTC_COSIM_COMPILE=0`` says not to; ``{"skipped": why}`` where the example cannot be built here.
    ``stop_time`` shortens each run of the trial (smoke tests)."""
    from orchestration.study.tuning import STOP_TIME

    stamp = {"date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
             "load_average_at_start": os.getloadavg()[0]}
    build = example_build()
    if build is None:
        return {**stamp, "skipped": f"needs the source checkout's {EXAMPLE_BUILD.parent} (not beside the package, "
                                    f"{PACKAGE_ROOT}, nor in the working folder)"}
    with tempfile.TemporaryDirectory(prefix=owner_prefix("sotc_bench_foreign_")) as tmp:
        built = subprocess.run([sys.executable, str(build), "--out", tmp], capture_output=True, text=True)
        if built.returncode != 0:
            why = (built.stderr.strip().splitlines() or [f"exit {built.returncode}"])[-1]
            return {**stamp, "skipped": f"examples/pd_controller did not build: {why}"}
        env = dict(os.environ)
        if compiled.requested() and compiled.unavailable() is None:
            # the host's child (orchestration.run.child) puts the package's folder first on its path unless it is
            # there already: with both on PYTHONPATH, the compiled cores first, both children import them
            cores = compiled_cores(Path(tmp) / "cores")
            env["PYTHONPATH"] = os.pathsep.join(p for p in (str(cores), str(PACKAGE_ROOT), env.get("PYTHONPATH")) if p)
        proc = subprocess.run([sys.executable, "-c", CHILD, str(Path(tmp) / FMU_NAME), str(repeats),
                               repr(stop_time or STOP_TIME)], cwd=tmp, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"the foreign trial failed: {proc.stderr.strip()[-500:]}")
    return {**stamp, **json.loads(proc.stdout.strip().splitlines()[-1])}


def _in_process(loop, point: dict, stop_time: float) -> dict:
    """One run of a trial in this process: ``pure_loop.metrics`` of it, no samples kept."""
    from orchestration.study.pure_loop import metrics

    return metrics(loop.run(PARAMETERS, stop_time=stop_time, samples=False, **point))


def _hosted(host, point: dict, stop_time: float) -> dict:
    """The same run through the host: its metrics, computed in the child."""
    run = host.run(PARAMETERS, stop_time=stop_time, **point)
    if run.failed:
        raise RuntimeError(f"a hosted run failed: {run.error}")
    return run.metrics


def measure(fmu: str, repeats: int, stop_time: float) -> dict:
    """In the child: ``repeats`` trials each way (runs of ``stop_time``) and the doStep loops, interleaved point by
    point (in-process and hosted in turn, first one then the other, then a run's steps of doStep), so that the
    three figures share the machine's moments: a shared machine's speed changes within a second. This process and
    the host's child run on one CPU (``_one_cpu``), so that hosted against in-process compares the isolation, not
    two CPUs; that ratio is the median over every point of every trial of its hosted run against its in-process
    run, measured back to back."""
    import fmu_controller.saturation
    from fmpy.fmi2 import fmi2True

    from fmu_plant.paper_setting import STEP_SIZE
    from orchestration.study.foreign_host import ForeignHost
    from orchestration.study.foreign_loop import ForeignLoop
    from orchestration.study.points import loop_arguments
    from orchestration.study.pure_loop import steps
    from orchestration.study.tuning import training_points

    points = [loop_arguments(p) for p in training_points()]
    n = steps(stop_time, STEP_SIZE)
    cores = "Python" if fmu_controller.saturation.__file__.endswith(".py") else "compiled"
    walls: dict[str, list[float]] = {"trial": [], "hosted": [], "do_step": []}
    ratios = []
    cpu = _one_cpu()
    with ForeignLoop(fmu, PORTS) as loop, ForeignHost(fmu, PORTS) as host:
        ways = {"trial": lambda p: _in_process(loop, p, stop_time), "hosted": lambda p: _hosted(host, p, stop_time)}
        if [ways["trial"](p) for p in points] != [ways["hosted"](p) for p in points]:  # and both warm
            raise RuntimeError("the hosted trial's metrics differ from the in-process trial's")
        if _cores_of(host.proc.pid) not in (cores, None):
            raise RuntimeError(f"the host's child did not import the cores this process did ({cores})")
        do_step, component = loop.ported.inner.raw_step, loop.ported.inner.fmu.component
        for _ in range(repeats):
            spent = dict.fromkeys(walls, 0.0)
            for i, point in enumerate(points):
                pair = {}
                for way in ("trial", "hosted")[::1 if i % 2 == 0 else -1]:
                    started = time.perf_counter()
                    ways[way](point)
                    pair[way] = time.perf_counter() - started
                    spent[way] += pair[way]
                ratios.append(pair["hosted"] / pair["trial"])
                started = time.perf_counter()  # on the instance the run left in step mode (the next run resets it)
                for k in range(n, 2 * n):
                    do_step(component, k * STEP_SIZE, STEP_SIZE, fmi2True)
                spent["do_step"] += time.perf_counter() - started
            for way, seconds in spent.items():
                walls[way].append(seconds * 1e6 / (len(points) * n))
        trials, reinstantiated, restarts = 1 + repeats, loop.reinstantiated, host.restarts
    figures = {way: _stats(us) for way, us in walls.items()}
    return {"benchmark": "foreign", "cores": cores, "repeats": repeats,
            "points": len(points), "stop_time": stop_time, "steps_per_run": n, "parameters": PARAMETERS,
            "us_per_step": figures, "beyond_us_per_step": figures["trial"]["median"] - figures["do_step"]["median"],
            "hosted_over_in_process": statistics.median(ratios), "cpu": cpu,
            "trials_per_load": trials, "reinstantiated": reinstantiated, "host_restarts": restarts}


def _one_cpu() -> int | None:
    """This process, and the children it starts from now on, kept to the first CPU it may run on (Linux); which,
    or None where the platform cannot say."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    cpu = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})
    return cpu


def _cores_of(pid: int) -> str | None:
    """What the process ``pid`` imported its cores as: a compiled core is a shared library in its memory map
    (Linux's /proc; None where there is none to read)."""
    maps = Path(f"/proc/{pid}/maps")
    if not maps.is_file():
        return None
    return "compiled" if f"{os.sep}fmu_plant{os.sep}dynamics." in maps.read_text() else "Python"


def _stats(samples: list[float]) -> dict:
    return {"median": statistics.median(samples), "min": min(samples), "max": max(samples)}


def line(row: dict) -> str:
    """The row as ``sotc-cosim bench`` prints it and docs/performance.md shows it."""
    what = "The benchmark's loop with a C controller FMU (examples/pd_controller, FMI 2.0"
    when = f"measured {row['date']}, load average at start {row['load_average_at_start']:.2f}"
    if "skipped" in row:
        return f"{what}): not measured ({when}): {row['skipped']}."
    f = row["us_per_step"]
    span = lambda k: f"{f[k]['median']:.2f} us ({f[k]['min']:.2f}-{f[k]['max']:.2f})"  # noqa: E731
    on_cpu = "" if row.get("cpu") is None else f", both processes on CPU {row['cpu']}"
    return (f"{what}; a trial: the {row['points']} training points of {row['stop_time']:g} s back to back, cores "
            f"{row['cores']}, {row['repeats']} trials each way, point by point in turn, median (min-max); {when}): "
            f"in-process {span('trial')} per step (set-up, resets and metrics included), of which the FMU's own doStep "
            f"{span('do_step')} per call (fmpy's fmi2DoStep function alone in a loop on the same instance: what is "
            f"subtracted), so {row['beyond_us_per_step']:.2f} us per step beyond it; through ForeignHost (a child "
            f"process{on_cpu}) {span('hosted')} per step, {row['hosted_over_in_process']:.2f}x in-process (the "
            f"median of each run's against its in-process twin's). The FMU was "
            f"loaded once for {row['trials_per_load']} trials ({row['trials_per_load'] * row['points']} runs), "
            f"reset between runs, instantiated again {row['reinstantiated']} times; the host's child was restarted "
            f"{row['host_restarts']} times.")


def figures(row: dict) -> dict[str, float]:
    """The row's figures ``sotc-cosim bench --compare`` sets beside an earlier run's."""
    if "us_per_step" not in row:
        return {}
    return {"C controller trial us/step": row["us_per_step"]["trial"]["median"],
            "C controller doStep us/call": row["us_per_step"]["do_step"]["median"],
            "C controller hosted / in-process": row["hosted_over_in_process"]}
