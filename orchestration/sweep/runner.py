"""Running a sweep (``orchestration.sweep.spec``) on Dask: one task per point, results on disk as
each point finishes, resume, per-point limits, Ctrl-C that keeps what finished.

Where the points run: ``orchestration.sweep.cluster`` (a local cluster of ``workers`` processes, or
an existing scheduler; the same for tune and optimum). On an existing cluster no shared folder is
needed: the FMUs are built here, sent once to every worker (``Client.scatter(broadcast=True)``) and
unpacked into a cache keyed by their SHA-256 digest in the worker's temp folder.

Every point is a task that never raises: a point whose scenario is refused, whose FMU reports an
error, whose state diverges (non-finite, or |phi|, |dphi| beyond ``state_bound``) or that runs
longer than ``time_limit`` (checked between blocks of ``GUARD_BLOCK`` samples, so a single FMU
call that never returns is not caught) comes back as a failed row with its reason; so does a task
whose worker process died. On Ctrl-C the local workers are ended at once; on an existing cluster
the pending points are cancelled, and a point already running on a remote worker finishes there
unseen (Dask cannot interrupt a running task). Rows are appended to ``points.jsonl`` in the output folder as they
arrive; a point whose key (its full scenario and the digests of its FMUs, ``point_key``) is
already there is not run again, so re-running the same command resumes, and a rebuilt FMU
invalidates the points that used it. Results never depend on the order points finish in: the
tables are written sorted by point index.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from orchestration import verified
from orchestration.fmu_build.build import ensure_built
from orchestration.outputs import atomic_write, private_folder
from orchestration.run.parameter_check import check_scenarios
from orchestration.run.scenario import FMU_FILE, Scenario
from orchestration.sweep.cluster import follow, open_client, shutdown
from orchestration.sweep.spec import Point, Sweep

GUARD_BLOCK = 100  # samples between two checks of the time limit and the state bound
TRACE_POINTS = 2000  # at most this many samples of the tracking error go into the sweep recording
STATES = ("phi1", "phi2", "dphi1", "dphi2")


def fmu_files(models: list[str], fmu_dir: Path, fmi: int = 2) -> dict[str, Path]:
    """Build what is missing of ours (FMI 2.0 or 3.0): model -> its file; an FMU file a scenario names is itself."""
    files = {m: Path(m) for m in models if m.endswith(FMU_FILE)}
    return {**ensure_built([m for m in models if m not in files], fmu_dir, fmi), **files}


def fmu_blobs(models: list[str], fmu_dir: Path, fmi: int = 2) -> dict[str, tuple[str, bytes]]:
    """Build what is missing and read every FMU (FMI 2.0 or 3.0): model -> (SHA-256 digest, file bytes)."""
    return _read(fmu_files(models, fmu_dir, fmi))


def _read(paths: dict[str, Path]) -> dict[str, tuple[str, bytes]]:
    out = {}
    for model, path in paths.items():
        data = Path(path).read_bytes()
        out[model] = (hashlib.sha256(data).hexdigest(), data)
    return out


def point_key(scenario: Scenario, digests: dict[str, str]) -> str:
    """What makes a point's result: its scenario (minus name and description) and its FMUs' digests."""
    identity = {
        "stop_time": scenario.stop_time, "step_size": scenario.step_size,
        "instances": {n: [i.fmu, dict(sorted(i.parameters.items()))] + ([dict(sorted(i.ports.items()))] if i.ports else [])
                      for n, i in sorted(scenario.instances.items())},
        "connect": list(scenario.by_name),
        "links": [[c.source, c.output, c.target, c.input] for c in scenario.links],
        "fmus": {i.fmu: digests[i.fmu] for i in scenario.instances.values()},
    }
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


# --- the task (runs on a worker) -------------------------------------------------------------------

class PointStopped(Exception):
    """Raised by the guard inside the run: the reason is the point's failure reason."""


class PointGuard:
    """A ``RunObserver`` that enforces the time limit and the state bound, keeps a thinned trace of
    the tracking error for the sweep recording, and forwards everything to ``inner`` (a recorder)."""

    def __init__(self, time_limit: float, state_bound: float, stride: int, inner=None):
        self.time_limit, self.state_bound, self.stride, self.inner = time_limit, state_bound, stride, inner
        self.reason: str | None = None
        self.trace: list[np.ndarray] = []
        self.offset = 0

    def start(self, scenario, columns, parameters) -> None:
        self.deadline = time.monotonic() + self.time_limit
        self.step_size = scenario.step_size
        where = {f"{inst}.{v}": (inst, i) for inst, names in columns.items() for i, v in enumerate(names)}
        self.states = [(s, *where[f"plant.{s}"]) for s in STATES if f"plant.{s}" in where]
        errors = [(where.get(f"plant.phi{j}"), where.get(f"reference.phi{j}_d")) for j in (1, 2)]
        self.errors = errors if all(a and b for a, b in errors) else None
        if self.inner is not None:
            self.inner.start(scenario, columns, parameters)

    def block(self, time_s: np.ndarray, rows: dict[str, np.ndarray]) -> None:
        if self.inner is not None:
            self.inner.block(time_s, rows)
        for name, inst, i in self.states:
            values = rows[inst][:, i]
            bad = np.flatnonzero(~(np.abs(values) <= self.state_bound))  # NaN is beyond any bound
            if len(bad):
                k = bad[0]
                self.reason = (f"diverged: plant.{name} = {values[k]:.6g} beyond the bound {self.state_bound:g} "
                               f"at t = {time_s[k]:.4f} s")
                raise PointStopped(self.reason)
        if self.errors is not None:
            keep = np.arange((-self.offset) % self.stride, len(time_s), self.stride)
            e = [rows[a[0]][keep, a[1]] - rows[b[0]][keep, b[1]] for a, b in self.errors]
            self.trace.append(np.column_stack([time_s[keep], *e]))
        self.offset += len(time_s)
        if time.monotonic() > self.deadline:
            self.reason = f"time limit of {self.time_limit:g} s exceeded"
            raise PointStopped(self.reason)

    def finish(self, result) -> None:
        if self.inner is not None:
            self.inner.finish(result)


def _fmu_cache(blobs: dict[str, tuple[str, bytes]]) -> dict[str, Path]:
    """Each FMU once per worker machine, in this user's private folder under its SHA-256 digest; a
    file already there is run only if its content still has that digest (else it is written again).
    Each folder is held while this worker lives (``orchestration.verified``): the caches' bound never
    removes it under a point."""
    root = private_folder(*verified.SENT)
    paths, made = {}, False
    for model, (digest, data) in blobs.items():
        target = root / digest / Path(model).with_suffix(FMU_FILE).name  # a model's, or the file's own name
        for _ in range(verified.ATTEMPTS):
            if verified.hold(target.parent) and target.is_file() and _sha256(target) == digest:
                break
            target.parent.mkdir(mode=0o700, exist_ok=True)
            atomic_write(target, data)
            made = True
        paths[model] = target
    if made:
        verified.trim()
    return paths


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def run_point(task: dict[str, Any], blobs: dict[str, tuple[str, bytes]]) -> dict[str, Any]:
    """One point: run, summarise, and return its row (never raises: a failure is a row). A point with an FMU file
    from elsewhere runs in a child process (``isolated``): its crash or hang fails the point, not the worker; it
    gets no more time without an answer than the point's time limit."""
    from orchestration.run.isolated import ANSWER_S, run_any
    from orchestration.run.summary import summarize

    point: Point = task["point"]
    scenario = point.scenario
    started = time.perf_counter()
    stride = max(1, int(np.ceil((scenario.steps + 1) / TRACE_POINTS)))
    row: dict[str, Any] = {"index": point.index, "key": task["key"], "settings": point.settings,
                           "worker": f"{socket.gethostname()}:{os.getpid()}"}
    scratch = Path(tempfile.mkdtemp(prefix="sotc_point_", dir=private_folder("scratch", task.get("scratch", "points"))))
    rrd_file = scratch / "point.rrd" if task["record"] else None
    guard = None
    answer_s = min(ANSWER_S, task["time_limit"])

    def run(scenario, paths, observer, block_size):
        return run_any(scenario, paths, observer, block_size, answer_s=answer_s)

    try:
        paths = _fmu_cache({m: blobs[m] for m in {i.fmu for i in scenario.instances.values()}})
        if rrd_file is None:
            guard = PointGuard(task["time_limit"], task["state_bound"], stride)
            result = run(scenario, paths, observer=guard, block_size=GUARD_BLOCK)
        else:
            from orchestration.recording.writer import PointRecorder

            with PointRecorder(rrd_file, point.settings, task["key"]) as recorder:
                guard = PointGuard(task["time_limit"], task["state_bound"], stride, recorder)
                result = run(scenario, paths, observer=guard, block_size=GUARD_BLOCK)
        summary = summarize(result)
        reason = _reason(guard.reason, result.error if result.failed else None)
    except Exception as exc:  # a refused scenario, an FMU that cannot load, a bug: this point fails
        summary = {"scenario": scenario.name, "controller": scenario.controller_fmu(),
                   "traceback": traceback.format_exc(limit=4)}
        reason = f"{type(exc).__name__}: {exc}"
    row.update(status="failed" if reason else "ok", reason=reason, summary=_json_safe(summary),
               wall_time_s=time.perf_counter() - started)
    trace = np.concatenate(guard.trace) if guard is not None and guard.trace else np.empty((0, 3))
    row["trace"] = trace
    row["rrd"] = None
    if rrd_file is not None and rrd_file.is_file():
        row["rrd"] = rrd_file.read_bytes()
    shutil.rmtree(scratch, ignore_errors=True)
    return row


def _reason(stopped: str | None, error: str | None) -> str | None:
    """Why a point failed: the guard's own stop (time limit, divergence) in its words, unless the run failed of
    something else first (an FMU file's run in its child: no answer, a crash), whose error says where."""
    first = error.split("; observer failed: ", 1)[0] if error else None  # what ended the run, before the guard
    if stopped is not None and (first is None or stopped in first):
        return stopped
    return first or stopped


def _json_safe(value: Any) -> Any:
    """Non-finite floats become None (JSON has no NaN), numpy scalars plain numbers."""
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


# --- the client side -------------------------------------------------------------------------------

@dataclass
class SweepOutcome:
    total: int
    skipped: int  # found on disk
    skipped_failed: int  # of those, failed ones
    ran: int
    failed: int  # among all points of the sweep, stored or new
    interrupted: bool = False
    rows: list[dict[str, Any]] = field(default_factory=list)  # every stored row of this sweep, by index


def execute(
    sweep: Sweep, fmu_dir: Path, store, workers: int | None = None, scheduler: str | None = None,
    record: bool = False, retry_failed: bool = False, listener=None, fmi: int = 2,
) -> SweepOutcome:
    """Run the points of ``sweep`` missing from ``store`` (a ``sweep.results.SweepStore``); rows are
    stored as they arrive. ``listener`` (optional) gets ``started(outcome)`` before the first point
    and ``finished(row)`` after each. Ctrl-C cancels the pending points, stops the workers and
    returns with ``interrupted`` set. ``fmi=3`` runs the FMI 3.0 FMUs (their digests key the points)."""
    paths = fmu_files(sweep.model_names(), fmu_dir, fmi)
    blobs = _read(paths)
    digests = {m: d for m, (d, _) in blobs.items()}
    points = sweep.points()
    # a value an FMU would refuse is an error in the sweep, not a failed point: refused before any run
    check_scenarios([p.scenario for p in points], paths)
    keys = [point_key(p.scenario, digests) for p in points]
    stored = store.load()
    todo = [(p, k) for p, k in zip(points, keys)
            if k not in stored or (retry_failed and stored[k]["status"] != "ok")]
    store.begin(sweep, keys)
    to_run = {k for _, k in todo}
    skipped = [stored[k] for k in keys if k in stored and k not in to_run]
    outcome = SweepOutcome(total=len(points), skipped=len(skipped), skipped_failed=sum(r["status"] != "ok" for r in skipped),
                           ran=0, failed=0)
    cluster = None
    if todo:
        private_folder(*verified.SENT)  # a cache folder others could write in is refused here, before any point
        cluster = open_client(scheduler, workers)  # unreachable: refused before the first line
    if listener is not None:
        listener.started(outcome)
    if todo:
        futures: list = []
        todo_by_key = {f"point-{p.index}-{k[:12]}-{cluster.scratch}": (p, k) for p, k in todo}

        def done(future) -> None:
            row = _row_of(future, todo_by_key[future.key])
            store.add(row)
            outcome.ran += 1
            if listener is not None:
                listener.finished(row)

        try:
            [shared] = cluster.client.scatter([blobs], broadcast=True, hash=False)
            base = {"time_limit": sweep.time_limit, "state_bound": sweep.state_bound, "record": record,
                    "scratch": cluster.scratch}
            futures = [cluster.client.submit(run_point, {**base, "point": p, "key": k}, shared, pure=False,
                                             key=task_key) for task_key, (p, k) in todo_by_key.items()]
            outcome.interrupted = follow(futures, done)
        except KeyboardInterrupt:  # Ctrl-C where SIGINT is not deferred (a library caller)
            outcome.interrupted = True
        finally:
            shutdown(cluster, futures, outcome.interrupted)  # a killed point's scratch goes too
    outcome.rows = store.rows()
    outcome.failed = sum(r["status"] != "ok" for r in outcome.rows)
    return outcome


def _row_of(future, point_and_key: tuple[Point, str]) -> dict[str, Any]:
    """The task's row, or a failed row when the task itself could not finish (its worker process
    died, e.g. killed or crashed inside an FMU, more often than Dask retries it)."""
    if future.status == "finished":
        return future.result()
    point, key = point_and_key
    exc = future.exception()
    return {"index": point.index, "key": key, "settings": point.settings, "status": "failed",
            "reason": f"the task did not finish: {type(exc).__name__}: {exc}", "summary": {}, "wall_time_s": None,
            "trace": None, "rrd": None}
