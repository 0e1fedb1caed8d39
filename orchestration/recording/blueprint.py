"""Default Rerun blueprints stored in the recordings (part of ``orchestration.recording.writer``).

A single run: the paper's figures over the whole run in two tabs ("Figs 1-5", "Figs 6-9"), their
transients in "First seconds" with the events log, and "FMU outputs" with one plot per FMU instance
(the raw layer). A comparison: the runs overlaid joint by joint (Figs 10-12). Views whose entities a
run lacks are left out, and views are laid out in full rows, so no container or grid cell is empty.

Every time-series view has its legend at the right top corner, in a strip right of the data: its time
axis runs on past the span it shows, by about 130 px (``ROOM``). Durations read "+40s", "+1m 20s" in Rerun's
plots (no timeline type or view setting gives plain seconds, ``docs/recordings.md``); the figures are
wide enough that every 10 s tick has its label, and the first seconds every 1 s.
"""
from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Sequence

import rerun.blueprint as rrb
from rerun.encodings import TimeRange, TimeRangeBoundary

from orchestration.recording.workspace import FRAME

if TYPE_CHECKING:
    from orchestration.recording.writer import RunWriter

TIMELINES = ("sim_time", "step")
# the 2D workspace as the view shows it (the recording mirrors y, so Y = 0.35 .. -1.95 on screen is the
# workspace's -0.35 .. 1.95): the base (0, 0) and its axis labels, the whole circle (47) (centre (1, 1),
# radius 0.5), the start of E, (1.88, 0.48), and the legend above the circle, with a margin
WORKSPACE_X = (-0.4, 2.25)
WORKSPACE_Y = (-1.95, 0.35)

LEGEND = rrb.PlotLegend(corner="RightTop", visible=True)
FIRST_SECONDS = 5.0  # the transients: learning, tracking, saturation and the bound (5)
PE_SECONDS = 1.0  # the probing signal (0.4 s in the paper) and the saturated optimal input tau*
ROW = 2  # views per row of the whole-run tabs: 10 s ticks need about 80 px each to be labelled
FIRST_ROW = 3  # views per row of "First seconds"
FIRST_SHARES = (4, 3)  # its first row is the taller: the legend of W1 ... W10 needs about 230 px
# a time axis spans ROOM x the time it shows, two or three views per row: the legend's strip right of
# the data (about 130 px of a 1600 px window)
ROOM, FIRST_ROOM = 1.2, 1.35
EVENT_LEVELS = ["CRITICAL", "ERROR", "WARN", "INFO"]  # the CL stack's growth (DEBUG) is left out

# short view titles (they must fit a view at 1600 x 1000) and what each shows, stored in the recording
# as the property "views"
VIEW_DESCRIPTIONS = {
    "Fig. 1-2: W": "Critic weights W1 ... W10 of eq. (27) (paper Fig. 1: paper-pe-only, Fig. 2: paper)",
    "Fig. 3: phi1": "Joint 1 position phi1 against the reference phi1_d [rad]",
    "Fig. 4: phi2": "Joint 2 position phi2 against the reference phi2_d [rad]",
    "Fig. 5: e": "Tracking errors e = phi - phi_d of both joints [rad]",
    "Fig. 6: tau*": "Saturated optimal inputs tau*_1, tau*_2 of eq. (28) [N.m]",
    "Fig. 7: tau^a": "Feedforward inputs tau^a_1, tau^a_2 of eq. (4) after the bound (5) [N.m]",
    "Fig. 8: tau": "Control torques tau1, tau2, their norm, and the limits +-rho [N.m]",
    "Fig. 9: path": "End-effector path E (red) against E_d (blue), up to the time cursor, the arm and its base, "
                    "on a 0.5 m grid [m]",
    "W, 0-5 s": "Learning: the critic weights W1 ... W10 over the first 5 s (Figs 1-2)",
    "e, 0-5 s": "Tracking errors e = phi - phi_d over the first 5 s (Fig. 5) [rad]",
    "tau, 0-5 s": "Saturation: tau1, tau2 and ||tau|| against +-rho over the first 5 s (Fig. 8) [N.m]",
    "tau^a, 0-5 s": "Feedforward inputs tau^a while the bound (5) clips them, first 5 s (Fig. 7) [N.m]",
    "tau*, 0-1 s": "Saturated optimal inputs tau* over the first second (Fig. 6) [N.m]",
    "PE, 0-1 s": "The probing signal PE added to both joint torques, first second [N.m]",
    "Events": "PE on/off, CL, tuning-law switches (30)/(31), clipping by (5) or the limit, FMU logs, the end",
    "Fig. 10: e1": "Joint 1 tracking error of every run [rad]",
    "Fig. 10: e2": "Joint 2 tracking error of every run [rad]",
    "Fig. 11: tau1": "Joint 1 torque of every run, with +-rho [N.m]",
    "Fig. 11: tau2": "Joint 2 torque of every run, with +-rho [N.m]",
    "||tau||": "Torque norm of every run, with the limit rho [N.m]",
    "Fig. 12: paths": "End-effector paths of every run (run colours) and the desired path (blue, drawn on top), "
                      "on a 0.5 m grid [m]",
}
TABS = ("Figs 1-5", "Figs 6-9", "First seconds", "FMU outputs")


@cache
def _whole_run() -> rrb.archetypes.TimeAxis:
    """Time-series x axis over the whole run, as the paper's figures show it (the viewer's default
    follows the cursor with a window of the latest samples). Made once and shared by every view: Rerun
    converts it to Arrow when it is made, about a millisecond each time."""
    return rrb.archetypes.TimeAxis(view_range=TimeRange(start=TimeRangeBoundary.infinite(), end=TimeRangeBoundary.infinite()))


@cache
def _time_axis(seconds: float, room: float) -> rrb.archetypes.TimeAxis:
    """0 .. ``seconds`` on ``sim_time``, then the legend's strip: ``room`` x ``seconds`` in all."""
    return rrb.archetypes.TimeAxis(view_range=TimeRange(start=TimeRangeBoundary.absolute(seconds=0.0),
                                                        end=TimeRangeBoundary.absolute(seconds=room * seconds)))


@cache
def _first(seconds: float, step_size: float) -> rrb.VisibleTimeRanges:
    """Only the samples of 0 .. ``seconds`` on both timelines, so that the y axis fits them."""
    return rrb.VisibleTimeRanges([
        rrb.VisibleTimeRange("sim_time", start=TimeRangeBoundary.absolute(seconds=0.0),
                             end=TimeRangeBoundary.absolute(seconds=seconds)),
        rrb.VisibleTimeRange("step", start=TimeRangeBoundary.absolute(seq=0),
                             end=TimeRangeBoundary.absolute(seq=round(seconds / step_size))),
    ])


def _event_columns() -> rrb.archetypes.TextLogColumns:
    """Time, level and text: the entity path (``/events/<topic>``) repeats what the text says."""
    kinds = {"LogLevel": True, "Body": True, "EntityPath": False}
    return rrb.archetypes.TextLogColumns(text_log_columns=[rrb.encodings.TextLogColumn(kind=k, visible=v)
                                                           for k, v in kinds.items()])


@cache
def _up_to_cursor() -> rrb.VisibleTimeRanges:
    """Everything from the start of the run up to the time cursor: the path drawn so far."""
    return rrb.VisibleTimeRanges([
        rrb.VisibleTimeRange(t, start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.cursor_relative())
        for t in TIMELINES
    ])


def _rows(views: Sequence, per_row: int, name: str | None = None, shares: Sequence[float] = ()) -> rrb.Container | None:
    """``views`` in rows of ``per_row``, the last row's views wider if it has fewer: no empty cell;
    ``shares``: the heights of the first rows (as many as there are)."""
    views = [v for v in views if v is not None]
    rows = [views[i:i + per_row] for i in range(0, len(views), per_row)]
    rows = [row[0] if len(row) == 1 else rrb.Horizontal(*row) for row in rows]
    return rrb.Vertical(*rows, name=name, row_shares=list(shares[:len(rows)]) or None) if rows else None


def _workspace_view(writers: Sequence["RunWriter"], name: str) -> rrb.Spatial2DView | None:
    contents, overrides = [], {}
    for w in writers:
        ws = w.entity("/workspace")
        if w.has_arm:
            contents += [f"{ws}/arm", f"{ws}/path/actual"]
            overrides[f"{ws}/path/actual"] = _up_to_cursor()
        if w.has_target:
            contents += [f"{ws}/target", f"{ws}/path/desired"]
            overrides[f"{ws}/path/desired"] = _up_to_cursor()
    if not contents:
        return None
    # origin "/" so that the mirror transforms logged at <prefix>/workspace (+y up) apply
    bounds = rrb.VisualBounds2D(x_range=WORKSPACE_X, y_range=WORKSPACE_Y)
    return rrb.Spatial2DView(origin="/", contents=[f"{FRAME}/**", *contents], name=name, overrides=overrides,
                             visual_bounds=bounds)


def run_blueprint(writer: "RunWriter") -> rrb.Blueprint:
    present = {g.path for g in writer.groups}
    stop, step = writer.scenario.stop_time, writer.scenario.step_size

    def plot(name: str, *paths: str, first: float | None = None) -> rrb.TimeSeriesView | None:
        if paths[0] not in present:
            return None
        window, axis = (None, _time_axis(stop, ROOM)) if first is None else (_first(first, step), _time_axis(first, FIRST_ROOM))
        return rrb.TimeSeriesView(origin="/", contents=[p for p in paths if p in present], name=name,
                                  axis_x=axis, plot_legend=LEGEND, time_ranges=window)

    W, e, tau, limit = "/controller/weights", "/tracking/error", "/torques/tau", "/torques/limit"
    torques = _rows([plot("Fig. 6: tau*", "/torques/tau_star"), plot("Fig. 7: tau^a", "/torques/tau_a"),
                     plot("Fig. 8: tau", tau, limit)], 1)
    path = _workspace_view([writer], "Fig. 9: path")
    first = _rows([plot("W, 0-5 s", W, first=FIRST_SECONDS), plot("e, 0-5 s", e, first=FIRST_SECONDS),
                   plot("tau, 0-5 s", tau, limit, first=FIRST_SECONDS),
                   plot("tau^a, 0-5 s", "/torques/tau_a", first=FIRST_SECONDS),
                   plot("tau*, 0-1 s", "/torques/tau_star", first=PE_SECONDS),
                   plot("PE, 0-1 s", "/controller/pe", first=PE_SECONDS)], FIRST_ROW, shares=FIRST_SHARES)
    raw = [rrb.TimeSeriesView(origin=f"/fmu/{inst}", name=inst, axis_x=_time_axis(stop, ROOM), plot_legend=LEGEND)
           for inst, names in writer.columns.items() if names]
    events = rrb.TextLogView(origin="/events", name="Events", rows=rrb.archetypes.TextLogRows(filter_by_log_level=EVENT_LEVELS),
                             columns=_event_columns())
    tabs = [
        _rows([plot("Fig. 1-2: W", W), plot("Fig. 3: phi1", "/joints/phi1"), plot("Fig. 4: phi2", "/joints/phi2"),
               plot("Fig. 5: e", e)], ROW, name=TABS[0]),
        _rows([torques, path], ROW, name=TABS[1]),
        rrb.Vertical(first, events, row_shares=[5, 2], name=TABS[2]) if first else rrb.Vertical(events, name=TABS[2]),
        _rows(raw, ROW, name=TABS[3]),
    ]
    return rrb.Blueprint(rrb.Tabs(*[t for t in tabs if t is not None]), rrb.TimePanel(timeline="sim_time", state="collapsed"),
                         rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"))


def comparison_blueprint(labels: Sequence[str], writers: Sequence["RunWriter"]) -> rrb.Blueprint:
    def overlay(name: str, suffix: str, extra: Sequence[str] = ()) -> rrb.TimeSeriesView | None:
        paths = [w.entity(suffix) for w in writers if w.entity(suffix) in {g.path for g in w.groups}]
        if not paths:
            return None
        return rrb.TimeSeriesView(origin="/", contents=paths + list(extra), name=name, axis_x=_whole_run())

    views = [
        overlay("Fig. 10: e1", "/tracking/e1"),
        overlay("Fig. 10: e2", "/tracking/e2"),
        overlay("Fig. 11: tau1", "/torques/tau1", ["/limit"]),
        overlay("Fig. 11: tau2", "/torques/tau2", ["/limit"]),
        overlay("||tau||", "/torques/norm", ["/limit"]),
    ]
    side = [rrb.TextLogView(origin="/", contents=[f"/{label}/events/**" for label in labels], name="Events")]
    ws = _workspace_view(writers, "Fig. 12: paths")
    if ws is not None:
        side.insert(0, ws)
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Grid(*[v for v in views if v is not None]), rrb.Vertical(*side, row_shares=[3, 1][: len(side)]),
                       column_shares=[3, 2]),
        rrb.TimePanel(timeline="sim_time"), collapse_panels=False,
    )


def sweep_blueprint() -> rrb.Blueprint:
    """A sweep: the tracking errors of every point overlaid, one view per joint."""
    views = [rrb.TimeSeriesView(origin="/", contents=[f"/points/*/e{j}"], name=f"joint {j} tracking error e{j} of every point [rad]",
                                axis_x=_whole_run()) for j in (1, 2)]
    return rrb.Blueprint(rrb.Vertical(*views), rrb.TimePanel(timeline="sim_time"), collapse_panels=False)
