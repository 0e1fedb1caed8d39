"""Default Rerun blueprints stored in the recordings (part of ``orchestration.recording.writer``).

A single run: the paper's figures over the whole run in two tabs ("Figs 1-5", "Figs 6-9"), their
transients in "First seconds" with the events log, and "FMU outputs" with one plot per FMU instance
(the raw layer). A comparison: the runs overlaid joint by joint, over the whole run ("Figs 10-11"),
their paths beside every run's events ("Fig. 12, events") and the first seconds. Views whose entities a run
lacks are left out, and views are laid out in full rows, so no container or grid cell is empty.

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
# a legend at 1600 x 1000: about 6.5 px a character of its longest name, 24 px for its marker and margins,
# beside a plot as wide as its share of the 1600 px row less 60 px (the y axis labels and the view's margins)
CHAR_PX, MARKER_PX, WINDOW_PX, MARGIN_PX = 6.5, 24, 1600, 60
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
    "Events": "PE on/off, CL, tuning-law switches (30)/(31), clipping by (5) or the limit, FMU logs, the end "
              "(a comparison: every run's, its text beginning with the run's name)",
    "Fig. 10: e1": "Joint 1 tracking error of every run [rad]",
    "Fig. 10: e2": "Joint 2 tracking error of every run [rad]",
    "Fig. 11: tau1": "Joint 1 torque of every run, with +-rho [N.m]",
    "Fig. 11: tau2": "Joint 2 torque of every run, with +-rho [N.m]",
    "||tau||": "Torque norm of every run, with the limit rho [N.m]",
    "Fig. 12: paths": "End-effector paths of every run (run colours) and the desired path (blue, drawn on top), "
                      "on a 0.5 m grid [m]",
    "e1, 0-5 s": "Joint 1 tracking error of every run over the first 5 s (Fig. 10) [rad]",
    "e2, 0-5 s": "Joint 2 tracking error of every run over the first 5 s (Fig. 10) [rad]",
    "tau1, 0-5 s": "Joint 1 torque of every run over the first 5 s, with +-rho (Fig. 11) [N.m]",
    "tau2, 0-5 s": "Joint 2 torque of every run over the first 5 s, with +-rho (Fig. 11) [N.m]",
    "||tau||, 0-5 s": "Torque norm of every run over the first 5 s, with the limit rho [N.m]",
}
TABS = ("Figs 1-5", "Figs 6-9", "First seconds", "FMU outputs")
COMPARE_TABS = ("Figs 10-11", "Fig. 12, events", TABS[2])


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


def _events(contents: Sequence[str]) -> rrb.TextLogView:
    """The events log: time, level and text (in a comparison, beginning with the run's name); the entity
    path (``/events/<topic>``) repeats what the text says, and the viewer cuts it short."""
    kinds = {"LogLevel": True, "Body": True, "EntityPath": False}
    columns = rrb.archetypes.TextLogColumns(text_log_columns=[rrb.encodings.TextLogColumn(kind=k, visible=v)
                                                              for k, v in kinds.items()])
    return rrb.TextLogView(origin="/", contents=list(contents), name="Events", columns=columns,
                           rows=rrb.archetypes.TextLogRows(filter_by_log_level=EVENT_LEVELS))


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


def _room(longest: int, per_row: int, least: float) -> float:
    """How far a time axis runs past what it shows (x the span, ``least`` at the least) so that a legend
    of names up to ``longest`` characters fits right of the data, ``per_row`` views a row."""
    plot = WINDOW_PX / per_row - MARGIN_PX
    return max(least, round(plot / (plot - CHAR_PX * longest - MARKER_PX), 2))


def _series(name: str, contents: Sequence[str], stop: float, step: float, first: float | None = None,
            room: float | None = None) -> rrb.TimeSeriesView:
    """``contents`` over the whole run (0 .. ``stop``) or over its first ``first`` seconds only, the
    legend at the right top in the strip its time axis keeps right of the data (``room``: ``_room``)."""
    if first is None:
        window, axis = None, _time_axis(stop, room or ROOM)
    else:
        window, axis = _first(first, step), _time_axis(first, room or FIRST_ROOM)
    return rrb.TimeSeriesView(origin="/", contents=list(contents), name=name, axis_x=axis, plot_legend=LEGEND,
                              time_ranges=window)


def _tabs(*tabs: rrb.Container | None) -> rrb.Blueprint:
    """The tabs that hold something; the side panels collapsed, the time panel reduced to its slider."""
    return rrb.Blueprint(rrb.Tabs(*[t for t in tabs if t is not None]), rrb.TimePanel(timeline="sim_time", state="collapsed"),
                         rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"))


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
        return _series(name, [p for p in paths if p in present], stop, step, first) if paths[0] in present else None

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
    events = _events(["/events/**"])
    return _tabs(
        _rows([plot("Fig. 1-2: W", W), plot("Fig. 3: phi1", "/joints/phi1"), plot("Fig. 4: phi2", "/joints/phi2"),
               plot("Fig. 5: e", e)], ROW, name=TABS[0]),
        _rows([torques, path], ROW, name=TABS[1]),
        rrb.Vertical(first, events, row_shares=[5, 2], name=TABS[2]) if first else rrb.Vertical(events, name=TABS[2]),
        _rows(raw, ROW, name=TABS[3]),
    )


# a comparison's time-series views: whole-run title, first-seconds title, the runs' entity, the extra entities
OVERLAYS = (("Fig. 10: e1", "e1", "/tracking/e1", ()), ("Fig. 10: e2", "e2", "/tracking/e2", ()),
            ("Fig. 11: tau1", "tau1", "/torques/tau1", ("/limit",)), ("Fig. 11: tau2", "tau2", "/torques/tau2", ("/limit",)),
            ("||tau||", "||tau||", "/torques/norm", ("/limit",)))


def comparison_blueprint(labels: Sequence[str], writers: Sequence["RunWriter"]) -> rrb.Blueprint:
    """The runs overlaid, under ``/<label>/``, two views a row (the legends name the runs: wider than a
    run's); the time axes span the longest run (or its first seconds), and the legend's strip fits the
    longest name in the row's share of the window (a view alone in its row needs less room)."""
    longest = max(writers, key=lambda w: w.scenario.stop_time).scenario
    stop, step = longest.stop_time, longest.step_size
    chars = max((len(s.label) for w in writers for g in w.groups for s in g.series), default=0)
    present = {g.path for w in writers for g in w.groups}
    shown = [(title, short, [w.entity(suffix) for w in writers if w.entity(suffix) in present] + list(extra))
             for title, short, suffix, extra in OVERLAYS if any(w.entity(suffix) in present for w in writers)]
    # the views of each one's row: the last row holds the rest
    in_row = [min(ROW, len(shown) - i // ROW * ROW) for i in range(len(shown))]

    def views(first: float | None) -> list[rrb.TimeSeriesView]:
        return [_series(title if first is None else f"{short}, 0-5 s", paths, stop, step, first, _room(chars, n, ROOM))
                for (title, short, paths), n in zip(shown, in_row)]

    return _tabs(
        _rows(views(None), ROW, name=COMPARE_TABS[0]),
        _rows([_workspace_view(writers, "Fig. 12: paths"), _events([f"/{label}/events/**" for label in labels])],
              ROW, name=COMPARE_TABS[1]),
        _rows(views(FIRST_SECONDS), ROW, name=COMPARE_TABS[2]),
    )


def sweep_blueprint() -> rrb.Blueprint:
    """A sweep: the tracking errors of every point overlaid, one view per joint."""
    views = [rrb.TimeSeriesView(origin="/", contents=[f"/points/*/e{j}"], name=f"joint {j} tracking error e{j} of every point [rad]",
                                axis_x=_whole_run()) for j in (1, 2)]
    return rrb.Blueprint(rrb.Vertical(*views), rrb.TimePanel(timeline="sim_time"), collapse_panels=False)
