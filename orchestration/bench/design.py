"""Measurements behind design choices (never timed tests): ``sotc-cosim bench [NAME ...]``.

``speed`` (the default): see ``orchestration.bench.speed``.

``integrator``: the plant's fixed-step RK4 with N substeps against scipy's DOP853 (rtol 1e-10)
on a 10 s torque profile with the torque held over each 0.01 s step, and the cost of one step.

``recording``: the 100 s ``paper`` scenario with and without the Rerun recording, alternated in
one process, 3 times each; the ratio of the median wall times (target: at most 1.10), and the
time spent inside the recorder itself (less sensitive to other load on the machine).

``recording-blocks``: the same at several block sizes (how ``recording.BLOCK_SIZE`` was chosen).

``sweep``: the same 8 sweep points (SOTC, 10 s each) as a plain loop in this process and as Dask
tasks on LocalClusters of 1 and of 2 workers, alternated in one run, best of 2 rounds (both
clusters started and warmed with a point per worker first; start-up reported apart): throughput,
the 2-worker speed-up (target >= 1.7 on 2 cores), the per-point overhead of Dask against the loop,
how many workers were busy on average (robust to other load on the machine), and as the ceiling the
same measure for plain pure-Python work in 2 processes against 1 (no Dask, no FMU).
"""
from __future__ import annotations

import math
import os
import time

import numpy as np

from fmu_plant.dynamics import STEP_SIZE as STEP
from fmu_plant.dynamics import ArmParameters, forward_dynamics, rk4_step
from fmu_plant.paper_setting import INITIAL_STATE


def excitation_torque(t: float) -> tuple[float, float]:
    """A 10 s torque profile that swings both joints back and forth (N.m)."""
    return 3.0 * math.sin(1.1 * t) + 1.0 * math.cos(3.7 * t), 1.5 * math.cos(0.9 * t) - 0.7 * math.sin(5.3 * t)


def dop853_zoh(state0, torque_at, steps: int, params: ArmParameters = ArmParameters(), step: float = STEP) -> np.ndarray:
    """Reference solution: DOP853 at rtol 1e-10, restarted at each step with the torque held."""
    from scipy.integrate import solve_ivp

    x = np.array(state0, dtype=float)
    out = [x.copy()]
    for k in range(steps):
        t1, t2 = torque_at(k * step)

        def rhs(_t, s, t1=t1, t2=t2):
            return [s[2], s[3], *forward_dynamics(s[1], s[2], s[3], t1, t2, params)]

        x = solve_ivp(rhs, (k * step, (k + 1) * step), x, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
        out.append(x.copy())
    return np.array(out)


def rk4_zoh(state0, torque_at, steps: int, substeps: int, params: ArmParameters = ArmParameters()) -> np.ndarray:
    x = tuple(state0)
    out = [x]
    for k in range(steps):
        x = rk4_step(x, *torque_at(k * STEP), STEP, substeps, params)
        out.append(x)
    return np.array(out)


INTEGRATOR_SUBSTEPS = (1, 2, 4, 8)


def integrator_errors(substeps=INTEGRATOR_SUBSTEPS, steps: int = 1000) -> list[tuple[int, float, float]]:
    """(N, max |phi error| rad, max |dphi error| rad/s) of RK4 with N substeps against DOP853 over the
    10 s excitation: deterministic, so docs/integration.md's table is generated from it."""
    state0 = INITIAL_STATE
    reference = dop853_zoh(state0, excitation_torque, steps)
    out = []
    for n in substeps:
        traj = rk4_zoh(state0, excitation_torque, steps, n)
        out.append((n, float(np.max(np.abs(traj[:, :2] - reference[:, :2]))),
                    float(np.max(np.abs(traj[:, 2:] - reference[:, 2:])))))
    return out


def bench_integrator() -> str:
    state0 = INITIAL_STATE
    lines = [
        "RK4 with N substeps vs DOP853 (rtol 1e-10), 10 s excitation, torque held per 0.01 s step",
        f"{'N':>3} {'max |phi err| rad':>18} {'max |dphi err| rad/s':>21} {'us per step':>12} {'cost vs N=1':>12}",
    ]
    base = None
    for n, err_q, err_w in integrator_errors():
        p = ArmParameters()
        reps = 3000
        t0 = time.perf_counter()
        for _ in range(reps):
            rk4_step(state0, 1.0, -0.5, STEP, n, p)
        us = (time.perf_counter() - t0) / reps * 1e6
        base = base or us
        lines.append(f"{n:>3} {err_q:>18.2e} {err_w:>21.2e} {us:>12.1f} {us / base:>12.2f}")
    return "\n".join(lines)


class _TimedRecorder:
    """A RunRecorder whose own time (start, blocks, finish and close) is added up, in all (``seconds``)
    and per call (``parts``)."""

    def __init__(self, recorder):
        self.recorder, self.seconds = recorder, 0.0
        self.parts = {"start": 0.0, "block": 0.0, "finish": 0.0}

    def _timed(self, part, method, *args):
        t0 = time.perf_counter()
        try:
            return method(*args)
        finally:
            spent = time.perf_counter() - t0
            self.seconds += spent
            self.parts[part] += spent

    def start(self, scenario, columns, parameters):
        self._timed("start", self.recorder.start, scenario, columns, parameters)

    def block(self, t, rows):
        self._timed("block", self.recorder.block, t, rows)

    def finish(self, result):
        self._timed("finish", self.recorder.finish, result)


def _timed_runs(block_sizes: list[int | None], fmu_dir, repeats: int = 3, scenario_name: str = "paper") -> dict:
    """Median wall time of a full run per block size (None: no recording), alternating the variants."""
    import statistics
    import tempfile
    from pathlib import Path

    from orchestration.fmu_build.build import ensure_built
    from orchestration.recording.writer import BLOCK_SIZE, RunRecorder
    from orchestration.run.master import run
    from orchestration.run.scenario import load_scenario

    scenario = load_scenario(scenario_name)
    paths = ensure_built(sorted({i.fmu for i in scenario.instances.values()}), fmu_dir)
    times: dict[int | None, list[float]] = {b: [] for b in block_sizes}
    own: dict[int | None, list[float]] = {b: [] for b in block_sizes if b is not None}
    sizes: dict[int | None, int] = {}
    with tempfile.TemporaryDirectory(prefix="sotc_bench_") as tmp:
        warm = Path(tmp) / "warm.rrd"
        with RunRecorder(warm) as rec:  # imports, first blueprint, FMU extraction
            run(scenario.with_stop_time(1.0), paths, observer=rec, block_size=BLOCK_SIZE)
        for _ in range(repeats):
            for block in block_sizes:
                target = Path(tmp) / f"run-{block}.rrd"
                t0 = time.perf_counter()
                if block is None:
                    result = run(scenario, paths)
                else:
                    timed = _TimedRecorder(RunRecorder(target))
                    with timed.recorder:
                        result = run(scenario, paths, observer=timed, block_size=block)
                    own[block].append(timed.seconds)
                times[block].append(time.perf_counter() - t0)
                if result.failed:
                    raise RuntimeError(f"benchmark run failed: {result.error}")
                if block is not None:
                    sizes[block] = target.stat().st_size
    return {"scenario": scenario, "median": {b: statistics.median(t) for b, t in times.items()}, "sizes": sizes,
            "own": {b: statistics.median(t) for b, t in own.items()}}


def bench_recording(fmu_dir) -> str:
    from orchestration.recording.writer import BLOCK_SIZE

    m = _timed_runs([None, BLOCK_SIZE], fmu_dir)
    sc, base, rec = m["scenario"], m["median"][None], m["median"][BLOCK_SIZE]
    return "\n".join([
        f"Rerun recording overhead: scenario {sc.name} ({sc.controller_fmu()}), {sc.stop_time:g} s, {sc.steps + 1} samples,"
        f" block size {BLOCK_SIZE}; medians of 3 alternated runs in one process",
        f"{'without recording':>20} {base:8.3f} s",
        f"{'with recording':>20} {rec:8.3f} s   ({m['sizes'][BLOCK_SIZE] / 1e6:.1f} MB .rrd)",
        f"{'ratio':>20} {rec / base:8.3f}   (target <= 1.10)",
        f"{'recorder own time':>20} {m['own'][BLOCK_SIZE]:8.3f} s   ({m['own'][BLOCK_SIZE] / base:.1%} of the run without recording)",
    ])


def bench_recording_blocks(fmu_dir) -> str:
    blocks = [250, 500, 1000, 2000, 5000]
    m = _timed_runs([None, *blocks], fmu_dir)
    base = m["median"][None]
    lines = [f"Recording overhead by block size: scenario {m['scenario'].name}, medians of 3 alternated runs",
             f"{'block':>8} {'wall s':>8} {'ratio':>7} {'recorder own s':>15}", f"{'none':>8} {base:8.3f} {1.0:7.3f}"]
    lines += [f"{b:>8} {m['median'][b]:8.3f} {m['median'][b] / base:7.3f} {m['own'][b]:15.3f}" for b in blocks]
    return "\n".join(lines)


def _spin(n: int) -> int:
    """A fixed amount of pure-Python work (the machine's own 2-process scaling reference)."""
    acc = 0
    for i in range(n):
        acc = (acc + i * i) % 1_000_003
    return acc


def machine_scaling(units: int = 4, n: int = 3_000_000) -> float:
    """Time of ``units`` pieces of pure-Python work in 1 process over the same work in 2 processes
    (no Dask, no FMU): what 2 processes can gain on this machine right now."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(2) as pool:
        list(pool.map(_spin, [1000] * 2))  # start both processes
        t0 = time.perf_counter()
        for _ in range(units):
            _spin(n)
        one = time.perf_counter() - t0
        t0 = time.perf_counter()
        list(pool.map(_spin, [n] * units))
        two = time.perf_counter() - t0
    return one / two


def bench_sweep(fmu_dir, points: int = 8, stop_time: float = 10.0, rounds: int = 2) -> str:
    from orchestration.sweep.cluster import open_client, shutdown
    from orchestration.sweep.runner import fmu_blobs, point_key, run_point
    from orchestration.sweep.spec import parse_sweep

    values = [float(v) for v in np.linspace(30.0, 70.0, points)]
    sweep = parse_sweep({"scenario": "paper", "stop_time": stop_time, "axis": [{"name": "controller.alpha1", "values": values}]},
                        "bench")
    blobs = fmu_blobs(sweep.model_names(), fmu_dir)
    digests = {m: d for m, (d, _) in blobs.items()}
    tasks = [{"point": p, "key": point_key(p.scenario, digests), "time_limit": 600.0, "state_bound": 1e3, "record": False}
             for p in sweep.points()]

    def timed(run_all) -> tuple[float, float]:
        """Wall time of the batch and the sum of the points' own wall times."""
        t0 = time.perf_counter()
        rows = run_all()
        wall = time.perf_counter() - t0
        bad = [r["reason"] for r in rows if r["status"] != "ok"]
        if bad:
            raise RuntimeError(f"benchmark point failed: {bad[0]}")
        return wall, sum(r["wall_time_s"] for r in rows)

    load = os.getloadavg()[0]
    clusters, started = {}, {}
    try:
        for workers in (1, 2):  # both clusters up (idle) before any timing; each warmed with a point per worker
            t0 = time.perf_counter()
            clusters[workers] = open_client(None, workers)
            started[workers] = time.perf_counter() - t0
        shared = {}
        for workers, cluster in clusters.items():
            client = cluster.client
            [shared[workers]] = client.scatter([blobs], broadcast=True, hash=False)
            client.gather([client.submit(run_point, t, shared[workers], pure=False) for t in tasks[:workers]])
        run_point(tasks[0], blobs)  # the loop's warm-up: imports, FMU cache
        variants = {"plain loop": lambda: [run_point(t, blobs) for t in tasks]}
        for workers, cluster in clusters.items():
            client = cluster.client
            variants[f"Dask, {workers} worker{'s' if workers > 1 else ''}"] = (
                lambda c=client, w=workers: c.gather([c.submit(run_point, t, shared[w], pure=False) for t in tasks]))
        best: dict[str, tuple[float, float]] = {}
        for _ in range(rounds):  # alternated, best of the rounds: other load on the machine only adds time
            for name, run_all in variants.items():
                wall, busy = timed(run_all)
                if name not in best or wall < best[name][0]:
                    best[name] = (wall, busy)
    finally:
        for cluster in clusters.values():
            shutdown(cluster, [], False)
    loop, one, two = (best[n][0] for n in variants)
    lines = [
        f"Sweep throughput: {points} points of scenario paper (SotcController), {stop_time:g} s each; best of {rounds} "
        f"alternated rounds (load average before: {load:.1f} on {os.cpu_count()} cores)",
        f"{'variant':>18} {'wall s':>8} {'points/s':>9} {'busy workers':>13} {'cluster start s':>16}",
    ]
    for name, (wall, busy) in best.items():
        workers = {"plain loop": None, **{f"Dask, {w} worker{'s' if w > 1 else ''}": w for w in (1, 2)}}[name]
        start = f"{started[workers]:16.2f}" if workers else f"{'-':>16}"
        lines.append(f"{name:>18} {wall:8.2f} {points / wall:9.2f} {busy / wall:13.2f} {start}")
    lines += [
        f"{'2 workers vs 1':>18} {one / two:8.2f}x  (target >= 1.7 on 2 otherwise idle cores)",
        f"{'machine reference':>18} {machine_scaling():8.2f}x  (pure-Python work in 2 processes vs 1, no Dask: the ceiling now)",
        f"{'Dask overhead':>18} {(one - loop) / points * 1e3:8.1f} ms per point (1 worker against the plain loop)",
        "busy workers = sum of the points' own wall times / batch wall time (2 = both workers always running a point)",
    ]
    return "\n".join(lines)
