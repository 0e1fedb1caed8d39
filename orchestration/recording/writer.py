"""Rerun recordings of runs (``.rrd`` files). With ``recording.blueprint`` (its default views) and
``recording.workspace`` (the path views' frame), in the only package of the project that imports rerun.

``RunRecorder`` is a ``RunObserver``: the master hands it the samples in blocks while the run
happens, and it sends each block with ``send_columns`` and flushes it to the file, so a run that
is killed loses at most the block in flight and the file written so far stays readable. The file
is finalised (footer written) by ``finish`` or, if the run raised, by leaving the ``with`` block.

Entity layout (one row per sample on every timeline-indexed entity; ``sim_time`` is a duration
of exactly ``step * round(T * 1e9)`` ns, ``step`` the sample index):

- ``/fmu/<instance>``: the raw layer, every Real output of the FMU instance, one ``Scalars`` batch
  per row in the FMU's output order (series named after the outputs). One entity per instance
  rather than per output: 8x cheaper to send (see README "Recordings").
- ``/joints/phi1``, ``/joints/phi2``: [phi_i, phi_i_d] (paper Figs 3-4).
- ``/tracking/error``: [e1, e2] = phi - phi_d (Fig. 5).
- ``/controller/weights``: [W1 .. W10] (Figs 1-2), ``/controller/pe``: the probing signal, when the
  controller has them.
- ``/torques/tau_star``, ``/torques/tau_a``: Figs 6-7, when the controller has them.
- ``/torques/tau``: [tau1, tau2, ||tau||]; ``/torques/limit``: [+rho, -rho] (Fig. 8).
- ``/workspace/arm``: the arm as a 2D line strip base -> elbow -> end effector; ``/workspace/target``:
  the desired end-effector point; ``/workspace/path/actual`` and ``/workspace/path/desired``: one
  segment per step (previous -> current point), shown up to the time cursor (Fig. 9); ``/workspace/frame``:
  static, its grid, axes, base and legend (``recording.workspace``).
- ``/events/<topic>``: text logs derived from the diagnostics (PE off, CL on, tuning-law switches,
  clipping by the bound (5) or the torque limit) and the run's end or failure.

``record_comparison`` writes several finished runs into one file under ``/<scenario>/...`` with a
blueprint that overlays them (paper Figs 10-12).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.encodings import Vec2DBatch

from orchestration.outputs import OutputError, PathLock
from orchestration.recording.rrd_file import RecordingFile
from orchestration.recording import BLOCK_SIZE
from orchestration.recording.blueprint import (
    VIEW_DESCRIPTIONS,
    run_blueprint,
)
from orchestration.recording.workspace import MIRROR, send_frame
from orchestration.run.scenario import Scenario

if TYPE_CHECKING:  # not imported: the master brings fmpy, which the writer process has no use for
    from orchestration.run.master import RunResult

COMPARE_BLOCK = 10_000  # samples per send_columns when a finished run is written at once

JOINT_COLORS = ((31, 119, 180), (255, 127, 14), (120, 120, 120))  # joint 1, joint 2, norm
ACTUAL, DESIRED, LIMIT = (220, 60, 40), (40, 110, 220), (150, 150, 150)
ARM_ALPHA = 110  # the arm is drawn half transparent over the path of E
DESIRED_DRAW_ORDER = 40.0  # above the runs' paths and arms (Rerun's default for 2D lines is 20)
PALETTE = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
           (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207))


def step_nanos(step_size: float) -> int:
    ns = round(step_size * 1e9)
    if ns <= 0 or abs(ns - step_size * 1e9) > 1e-6 * ns:
        raise ValueError(f"step size {step_size} s is not a whole number of nanoseconds")
    return ns


def strips_column(strips: np.ndarray) -> pa.Array:
    """(m, p, 2) line strips, one per step, as the Arrow array of ``rr.LineStrips2D.columns``: the offsets
    from numpy (rerun's own conversion walks the strips one by one in Python: most of the recording's
    cost per step)."""
    m, p, _ = strips.shape
    inner = Vec2DBatch(strips.reshape(m * p, 2)).as_arrow_array()
    offsets = pa.array(np.arange(0, (m + 1) * p, p, dtype=np.int32), type=pa.int32())
    return pa.ListArray.from_arrays(offsets, inner, type=rr.components.LineStrip2DBatch._ARROW_DATATYPE)


def time_columns(steps: np.ndarray, step_ns: int) -> list[rr.TimeColumn]:
    """The two timelines of every row: ``sim_time`` = step * T as integer nanoseconds, and ``step``."""
    return [rr.TimeColumn("sim_time", duration=(steps * step_ns).astype("timedelta64[ns]")),
            rr.TimeColumn("step", sequence=steps)]


# --- what is sent -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Series:
    """One line of a grouped entity: an output ("instance.variable"), a difference, a norm or a constant."""

    label: str
    color: tuple[int, int, int]
    keys: tuple[str, ...] = ()
    op: str = "get"  # get | diff | norm | const
    value: float = 0.0

    def evaluate(self, col: dict[str, np.ndarray], m: int) -> np.ndarray:
        if self.op == "get":
            return col[self.keys[0]]
        if self.op == "diff":
            return col[self.keys[0]] - col[self.keys[1]]
        if self.op == "norm":
            return np.hypot(col[self.keys[0]], col[self.keys[1]])
        return np.full(m, self.value)


@dataclass(frozen=True)
class Group:
    """An entity with several scalar series per row (one ``Scalars`` batch of len(series))."""

    path: str
    series: tuple[Series, ...]

    def needs(self) -> set[str]:
        return {k for s in self.series for k in s.keys}


def _pair(path: str, a: str, b: str, labels: tuple[str, str], colors=(ACTUAL, DESIRED)) -> Group:
    return Group(path, (Series(labels[0], colors[0], (a,)), Series(labels[1], colors[1], (b,))))


def run_groups(scenario: Scenario) -> list[Group]:
    """The grouped entities of a single-run recording (kept only if their outputs exist)."""
    rho = scenario.torque_limit()
    groups = [
        _pair(f"/joints/phi{i}", f"plant.phi{i}", f"reference.phi{i}_d", (f"phi{i} [rad]", f"phi{i}_d [rad]"))
        for i in (1, 2)
    ]
    groups.append(Group("/tracking/error", tuple(
        Series(f"e{i} [rad]", JOINT_COLORS[i - 1], (f"plant.phi{i}", f"reference.phi{i}_d"), "diff") for i in (1, 2))))
    groups.append(Group("/controller/weights", tuple(
        Series(f"W{k}", PALETTE[k - 1], (f"controller.W{k}",)) for k in range(1, 11))))
    groups.append(Group("/controller/pe", (Series("PE [N.m]", JOINT_COLORS[2], ("controller.pe",)),)))
    for name, label in (("tau_star", "tau*"), ("tau_a", "tau^a")):
        groups.append(_pair(f"/torques/{name}", f"controller.{name}1", f"controller.{name}2",
                            (f"{label}1 [N.m]", f"{label}2 [N.m]"), JOINT_COLORS))
    groups.append(Group("/torques/tau", (
        Series("tau1 [N.m]", JOINT_COLORS[0], ("controller.tau1",)),
        Series("tau2 [N.m]", JOINT_COLORS[1], ("controller.tau2",)),
        Series("||tau|| [N.m]", JOINT_COLORS[2], ("controller.tau1", "controller.tau2"), "norm"),
    )))
    groups.append(Group("/torques/limit", (  # constants; keyed on tau1 so they exist with a torque
        Series(f"+rho = {rho:g} N.m", LIMIT, ("controller.tau1",), "const", rho),
        Series(f"-rho = {-rho:g} N.m", LIMIT, ("controller.tau1",), "const", -rho),
    )))
    return groups


def comparison_groups(prefix: str, label: str, color: tuple[int, int, int]) -> list[Group]:
    """One series per entity, coloured per run, so that views can overlay runs joint by joint."""
    groups = []
    for i in (1, 2):
        groups.append(Group(f"{prefix}/tracking/e{i}", (
            Series(f"{label}: e{i} [rad]", color, (f"plant.phi{i}", f"reference.phi{i}_d"), "diff"),)))
        groups.append(Group(f"{prefix}/torques/tau{i}", (Series(f"{label}: tau{i} [N.m]", color, (f"controller.tau{i}",)),)))
    groups.append(Group(f"{prefix}/torques/norm", (
        Series(f"{label}: ||tau|| [N.m]", color, ("controller.tau1", "controller.tau2"), "norm"),)))
    return groups


# (key, entity, message when it becomes non-zero, level, message when it returns to zero, level)
EDGE_EVENTS = (
    ("controller.pe_active", "pe", "PE on: the probing signal is added to the torque", "INFO",
     "PE switched off: the probing signal ends", "INFO"),
    ("controller.tau_a_bounded", "clipping", "bound (5) clips the feedforward torque tau^a", "WARN",
     "bound (5) no longer clips tau^a", "INFO"),
    ("controller.chi_a_bounded", "clipping", "bound (5) clips the feedforward velocity chi_vd^a", "WARN",
     "bound (5) no longer clips chi_vd^a", "INFO"),
    ("controller.tau_limited", "clipping", "the actuator limit rho clips tau", "WARN",
     "the actuator limit rho no longer clips tau", "INFO"),
    ("controller.saturated", "clipping", "saturation: ||tau|| scaled down to the bound", "WARN",
     "saturation ends: ||tau|| inside the bound", "INFO"),
)


def _change_messages(key: str, old: np.ndarray, new: np.ndarray) -> tuple[list[str], list[str]]:
    if key == "controller.tuning_law":
        texts = [f"tuning law ({n:.0f}) in force" + ("" if math.isnan(o) else f", was ({o:.0f})") for o, n in zip(old, new)]
        return texts, ["INFO"] * len(texts)
    # controller.cl_stack_size
    texts, levels = [], []
    for o, n in zip(old, new):
        if (math.isnan(o) or o == 0) and n > 0:
            texts.append(f"CL switched on: the stack holds {n:.0f} record(s)")
            levels.append("INFO")
        else:
            texts.append(f"CL stack holds {n:.0f} record(s)")
            levels.append("DEBUG")
    return texts, levels


# (key, entity, value assumed before the first sample: NaN reports the first value)
CHANGE_EVENTS = (("controller.tuning_law", "tuning_law", math.nan), ("controller.cl_stack_size", "cl", 0.0))

WORKSPACE_KEYS = ("plant.elbow_x", "plant.elbow_y", "plant.ee_x", "plant.ee_y")
TARGET_KEYS = ("reference.x_d", "reference.y_d")


class RunWriter:
    """Sends one run (under an entity prefix) to a stream: statics once, then blocks of samples."""

    def __init__(self, scenario: Scenario, columns: dict[str, list[str]], groups: Iterable[Group],
                 prefix: str = "", raw: bool = True, arm_color=ACTUAL):
        self.stream: rr.RecordingStream | None = None  # set before anything is sent
        self.scenario, self.prefix, self.raw = scenario, prefix, raw
        self.columns = {inst: list(names) for inst, names in columns.items()}
        self.where = {f"{inst}.{v}": (inst, i) for inst, names in self.columns.items() for i, v in enumerate(names)}
        self.groups = [g for g in groups if g.needs() <= set(self.where)]
        self.step_ns = step_nanos(scenario.step_size)
        self.next_step = 0
        self.has_arm = all(k in self.where for k in WORKSPACE_KEYS)
        self.has_target = all(k in self.where for k in TARGET_KEYS)
        self.arm_color = arm_color
        self.last_point: dict[str, np.ndarray] = {}
        self.edges = [e for e in EDGE_EVENTS if e[0] in self.where]
        self.changes = [c for c in CHANGE_EVENTS if c[0] in self.where]
        self.previous: dict[str, float] = {e[0]: 0.0 for e in self.edges} | {c[0]: c[2] for c in self.changes}

    def entity(self, path: str) -> str:
        return f"{self.prefix}{path}"

    def send_static(self) -> None:
        log = self.stream.log
        if self.raw:
            for inst, names in self.columns.items():
                if names:
                    log(self.entity(f"/fmu/{inst}"), rr.SeriesLines(
                        names=names, colors=[PALETTE[i % len(PALETTE)] for i in range(len(names))]), static=True)
        for g in self.groups:
            log(g.path, rr.SeriesLines(names=[s.label for s in g.series], colors=[s.color for s in g.series]),
                static=True)
        ws = self.entity("/workspace")
        if self.has_arm or self.has_target:
            log(ws, MIRROR, static=True)  # the 2D view draws +y downwards: mirrored, +y points up
            if not self.prefix:  # a comparison has one frame for all its runs
                arm = [("E: actual path", self.arm_color), ("arm at the time cursor", (*self.arm_color, ARM_ALPHA))]
                send_frame(self.stream, arm * self.has_arm + [("E_d: desired path (47)", DESIRED)] * self.has_target,
                           mirror=False)
        if self.has_arm:
            # the arm in the run's colour, half transparent and thinner than before, so the path of E
            # (same colour, opaque) stays readable underneath it
            log(f"{ws}/arm", rr.LineStrips2D.from_fields(colors=[(*self.arm_color, ARM_ALPHA)], radii=[0.012]), static=True)
            log(f"{ws}/path/actual", rr.LineStrips2D.from_fields(colors=[self.arm_color], radii=[0.006]), static=True)
        if self.has_target:
            # drawn above every run's path and arm (DrawOrder), thin, so that it stays visible where runs
            # overlay it (Fig. 12)
            log(f"{ws}/target", rr.Points2D.from_fields(colors=[DESIRED], radii=[0.04], draw_order=DESIRED_DRAW_ORDER + 1),
                static=True)
            log(f"{ws}/path/desired", rr.LineStrips2D.from_fields(colors=[DESIRED], radii=[0.004],
                                                                   draw_order=DESIRED_DRAW_ORDER), static=True)

    def send_block(self, rows: dict[str, np.ndarray], every: int = 1) -> None:
        """The next samples (per instance an array (m, n_outputs)). ``every`` > 1 sends the signals
        at every ``every``-th step only (k % every == 0); the events still look at every sample."""
        m = len(next(iter(rows.values()))) if rows else 0
        if m == 0:
            return
        steps = np.arange(self.next_step, self.next_step + m, dtype=np.int64)
        self.next_step += m
        self._send_events(steps, {key: rows[inst][:, i] for key, (inst, i) in self.where.items()})
        if every > 1:
            keep = np.flatnonzero(steps % every == 0)
            if len(keep) == 0:
                return
            steps, rows = steps[keep], {inst: r[keep] for inst, r in rows.items()}
            m = len(keep)
        index = time_columns(steps, self.step_ns)
        col = {key: rows[inst][:, i] for key, (inst, i) in self.where.items()}
        send = self.stream.send_columns
        if self.raw:
            for inst, names in self.columns.items():
                if names:
                    send(self.entity(f"/fmu/{inst}"), index, rr.Scalars.columns(scalars=rows[inst]))
        for g in self.groups:
            send(g.path, index, rr.Scalars.columns(scalars=np.column_stack([s.evaluate(col, m) for s in g.series])))
        ws = self.entity("/workspace")
        if self.has_arm:
            ee = np.column_stack([col["plant.ee_x"], col["plant.ee_y"]])
            elbow = np.column_stack([col["plant.elbow_x"], col["plant.elbow_y"]])
            send(f"{ws}/arm", index, rr.LineStrips2D.columns(strips=strips_column(np.stack([np.zeros_like(ee), elbow, ee], axis=1))))
            send(f"{ws}/path/actual", index, rr.LineStrips2D.columns(strips=strips_column(self._segments("actual", ee))))
        if self.has_target:
            target = np.column_stack([col["reference.x_d"], col["reference.y_d"]])
            send(f"{ws}/target", index, rr.Points2D.columns(positions=target))
            send(f"{ws}/path/desired", index,
                 rr.LineStrips2D.columns(strips=strips_column(self._segments("desired", target))))

    def _segments(self, name: str, points: np.ndarray) -> np.ndarray:
        """Per step the segment from the previous sample's point to this one (the first: a dot)."""
        before = np.empty_like(points)
        before[0] = self.last_point.get(name, points[0])
        before[1:] = points[:-1]
        self.last_point[name] = points[-1].copy()
        return np.stack([before, points], axis=1)

    def _send_events(self, steps: np.ndarray, col: dict[str, np.ndarray]) -> None:
        found: dict[str, list[tuple[int, str, str]]] = {}
        for key, topic, on, on_level, off, off_level in self.edges:
            values = col[key] != 0
            flags = np.concatenate(([self.previous[key] != 0], values))
            for j in np.flatnonzero(flags[1:] != flags[:-1]):
                found.setdefault(topic, []).append((int(steps[j]), on if values[j] else off, on_level if values[j] else off_level))
            self.previous[key] = float(values[-1])
        for key, topic, _ in self.changes:
            values = np.concatenate(([self.previous[key]], col[key]))
            idx = np.flatnonzero(values[1:] != values[:-1])  # a NaN start fires at the first sample
            if len(idx):
                texts, levels = _change_messages(key, values[idx], values[idx + 1])
                found.setdefault(topic, []).extend(zip(steps[idx].tolist(), texts, levels))
            self.previous[key] = float(values[-1])
        for topic, events in found.items():
            events.sort(key=lambda e: e[0])
            self.send_events(topic, events)

    def send_events(self, topic: str, events: Sequence[tuple[int, str, str]]) -> None:
        steps = np.array([e[0] for e in events], dtype=np.int64)
        run = f"{self.prefix[1:]}: " if self.prefix else ""  # a comparison's runs share one events view
        self.stream.send_columns(
            self.entity(f"/events/{topic}"), time_columns(steps, self.step_ns),
            rr.TextLog.columns(text=[run + e[1] for e in events], level=[e[2] for e in events]),
        )

    def send_end(self, result: RunResult) -> None:
        last = max(result.samples - 1, 0)
        logs = [(min(max(r.sample, 0), last), f"{r.instance}: {r.message}", _FMI_LEVELS.get(r.status, "INFO"))
                for r in result.logs if r.status != "OK"]
        if logs:
            self.send_events("fmu_log", logs)
        if result.failed:
            self.send_events("run", [(last, f"run FAILED after {result.samples} samples: {result.error}", "ERROR")])
        else:
            self.send_events("run", [(last, f"run finished: {result.samples} samples in {result.wall_time_s:.2f} s wall time", "INFO")])


_FMI_LEVELS = {"WARNING": "WARN", "DISCARD": "WARN", "ERROR": "ERROR", "FATAL": "CRITICAL", "PENDING": "DEBUG"}


def send_scenario_properties(
    stream: rr.RecordingStream, scenario: Scenario, parameters: dict[str, dict[str, float]] | None = None,
    prefix: str = "", fmus: dict[str, dict[str, str]] | None = None,
) -> None:
    """The scenario, and per instance its FMU (name, and once the run has loaded it its GUID, version
    and generation tool) and every parameter value it ran with (read back from the FMU, defaults
    included; the scenario's overrides where the run never got that far)."""
    stream.send_property(f"{prefix}scenario", rr.AnyValues(
        name=scenario.name, description=scenario.description, stop_time=scenario.stop_time,
        step_size=scenario.step_size, steps=scenario.steps, controller=scenario.controller_fmu() or "",
        torque_limit=scenario.torque_limit(),
        connect=[f"{a} -> {b}" for a, b in scenario.by_name],
        connections=[f"{c.source}.{c.output} -> {c.target}.{c.input}" for c in scenario.links],
    ))
    for inst in scenario.instances.values():
        values = (parameters or {}).get(inst.name) or inst.parameters
        ids = (fmus or {}).get(inst.name, {})
        stream.send_property(f"{prefix}{inst.name}", rr.AnyValues(fmu=inst.fmu, **{f"fmu_{k}": v for k, v in ids.items()},
                                                                   **values))


def send_view_properties(stream: rr.RecordingStream) -> None:
    """What each default view shows (the view titles are kept short enough to read)."""
    stream.send_property("views", rr.AnyValues(**VIEW_DESCRIPTIONS))


def send_result_properties(stream: rr.RecordingStream, result: RunResult, prefix: str = "") -> None:
    stream.send_property(f"{prefix}result", rr.AnyValues(
        status="interrupted" if result.interrupted else "failed" if result.failed else "ok", samples=result.samples, wall_time_s=result.wall_time_s,
        error=result.error or "",
    ))


# --- the observer -------------------------------------------------------------------------------

class RunRecorder:
    """Streams a run to ``path`` (a ``RunObserver``). Use as a context manager around ``run``: entering
    locks ``path`` (a second writer gets ``UsageError``), leaving finalises the file even if the run
    raises::

        with RunRecorder(path) as rec:
            result = run(scenario, fmu_paths, observer=rec, block_size=BLOCK_SIZE)

    A write that fails ends the recording (the run then fails, naming it) and is kept as
    ``output_error`` for the caller; the file is then not created.
    """

    def __init__(self, path: str | Path, every: int = 1):
        if every < 1:
            raise ValueError(f"record every N-th sample needs N >= 1, got {every}")
        self.path = Path(path)
        self.every = every  # decimation for long runs: every N-th sample's signals (events: all)
        self.lock: PathLock | None = None
        self.file: RecordingFile | None = None
        self.stream: rr.RecordingStream | None = None
        self.writer: RunWriter | None = None
        self.closed = False
        self.output_error: OutputError | None = None

    def start(self, scenario: Scenario, columns: dict[str, list[str]],
              parameters: dict[str, dict[str, float]] | None = None) -> None:
        self.writer = RunWriter(scenario, columns, run_groups(scenario))
        self.file = RecordingFile(self.path, run_blueprint(self.writer), self.lock)
        self.stream = self.writer.stream = self.file.stream
        self.stream.send_recording_name(scenario.name)
        send_scenario_properties(self.stream, scenario, parameters)
        self.stream.send_property("recording", rr.AnyValues(record_every=self.every))
        send_view_properties(self.stream)
        self.writer.send_static()
        self._flush()

    def _flush(self) -> None:
        try:
            self.file.flush()
        except OutputError as exc:
            self.output_error = exc
            raise

    def block(self, time: np.ndarray, rows: dict[str, np.ndarray]) -> None:
        if len(time) and round(time[0] / self.writer.scenario.step_size) != self.writer.next_step:
            raise ValueError(f"block starts at t = {time[0]} s, expected sample {self.writer.next_step}")
        self.writer.send_block(rows, self.every)
        self._flush()  # the block is in the file before the run goes on

    def finish(self, result: RunResult) -> None:
        if self.output_error is not None:
            return
        if self.stream is None:  # failed before the first sample: record why
            self.start(result.scenario, {}, result.parameters)
        self.writer.send_end(result)
        send_scenario_properties(self.stream, result.scenario, result.parameters, fmus=result.fmus)
        send_result_properties(self.stream, result)
        self.close()

    def close(self, error: BaseException | None = None) -> None:
        if self.closed:
            return
        self.closed = True
        if self.file is None:  # never started
            if self.lock is not None:
                self.lock.release()
            return
        if error is not None and not self.file.failed:
            self.writer.send_events("run", [(max(self.writer.next_step - 1, 0), f"run aborted: {error!r}", "ERROR")])
        try:
            self.file.close()
        except OutputError as exc:
            if self.output_error is None:  # a new failure (an earlier one was reported already)
                self.output_error = exc
                raise

    def __enter__(self) -> "RunRecorder":
        self.lock = PathLock(self.path, "recording").acquire()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(exc)


class PointRecorder(RunRecorder):
    """The recording of one point of a sweep: a run recording whose properties also hold the
    point's settings (``sweep_point``) and its resume key."""

    def __init__(self, path: str | Path, settings: dict[str, object], key: str):
        super().__init__(path)
        self.settings, self.key = settings, key

    def start(self, scenario: Scenario, columns: dict[str, list[str]],
              parameters: dict[str, dict[str, float]] | None = None) -> None:
        super().start(scenario, columns, parameters)
        self.stream.send_property("sweep_point", rr.AnyValues(
            key=self.key, **{name.replace(".", "/"): value for name, value in self.settings.items()}))
