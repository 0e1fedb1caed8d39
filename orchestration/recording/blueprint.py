"""Default Rerun blueprints stored in the recordings (part of ``orchestration.recording.writer``).

A single run: a "Paper figures" tab whose views reproduce section 4 of the paper (Figs 1-9) plus an
events log, and an "FMU outputs" tab with one plot per FMU instance (the raw layer). A comparison:
the runs overlaid joint by joint (Figs 10-12). Views whose entities a run lacks are left out.
"""
from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Sequence

import rerun.blueprint as rrb
from rerun.encodings import TimeRange, TimeRangeBoundary

if TYPE_CHECKING:
    from orchestration.recording.writer import RunWriter

TIMELINES = ("sim_time", "step")
# the 2D workspace as the view shows it (the recording mirrors y, so Y = 0.3 .. -1.8 on screen is the
# workspace's -0.3 .. 1.8): the base (0, 0), the whole circle (47) (centre (1, 1), radius 0.5) and the
# start of E, (1.88, 0.48), with a margin
WORKSPACE_X = (-0.3, 2.1)
WORKSPACE_Y = (-1.8, 0.3)

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
    "Fig. 9: path": "End-effector path E (red) against E_d (blue), up to the time cursor, and the arm [m]",
    "Events": "PE on/off, CL, tuning-law switches (30)/(31), clipping by (5) or the limit, FMU logs, the end",
    "Fig. 10: e1": "Joint 1 tracking error of every run [rad]",
    "Fig. 10: e2": "Joint 2 tracking error of every run [rad]",
    "Fig. 11: tau1": "Joint 1 torque of every run, with +-rho [N.m]",
    "Fig. 11: tau2": "Joint 2 torque of every run, with +-rho [N.m]",
    "||tau||": "Torque norm of every run, with the limit rho [N.m]",
    "Fig. 12: paths": "End-effector paths of every run (run colours) and the desired path (blue, drawn on top) [m]",
}


@cache
def _whole_run() -> rrb.archetypes.TimeAxis:
    """Time-series x axis over the whole run, as the paper's figures show it (the viewer's default
    follows the cursor with a window of the latest samples). Made once and shared by every view: Rerun
    converts it to Arrow when it is made, about a millisecond each time."""
    return rrb.archetypes.TimeAxis(view_range=TimeRange(start=TimeRangeBoundary.infinite(), end=TimeRangeBoundary.infinite()))


@cache
def _up_to_cursor() -> rrb.VisibleTimeRanges:
    """Everything from the start of the run up to the time cursor: the path drawn so far."""
    return rrb.VisibleTimeRanges([
        rrb.VisibleTimeRange(t, start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.cursor_relative())
        for t in TIMELINES
    ])


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
    # origin "/" so that the mirror transform logged at <prefix>/workspace (+y up) applies
    bounds = rrb.VisualBounds2D(x_range=WORKSPACE_X, y_range=WORKSPACE_Y)
    return rrb.Spatial2DView(origin="/", contents=contents, name=name, overrides=overrides, visual_bounds=bounds)


def run_blueprint(writer: "RunWriter") -> rrb.Blueprint:
    present = {g.path for g in writer.groups}
    figures = []

    def plot(name: str, *paths: str) -> None:
        if paths[0] in present:
            figures.append(rrb.TimeSeriesView(origin="/", contents=[p for p in paths if p in present], name=name,
                                              axis_x=_whole_run()))

    plot("Fig. 1-2: W", "/controller/weights")
    plot("Fig. 3: phi1", "/joints/phi1")
    plot("Fig. 4: phi2", "/joints/phi2")
    plot("Fig. 5: e", "/tracking/error")
    plot("Fig. 6: tau*", "/torques/tau_star")
    plot("Fig. 7: tau^a", "/torques/tau_a")
    plot("Fig. 8: tau", "/torques/tau", "/torques/limit")
    side = [rrb.TextLogView(origin="/events", name="Events")]
    ws = _workspace_view([writer], "Fig. 9: path")
    if ws is not None:
        side.insert(0, ws)
    raw = [rrb.TimeSeriesView(origin=f"/fmu/{inst}", name=inst, axis_x=_whole_run())
           for inst, names in writer.columns.items() if names]
    tabs = [rrb.Horizontal(rrb.Grid(*figures), rrb.Vertical(*side, row_shares=[3, 1][: len(side)]),
                           column_shares=[3, 2], name="Paper figures")]
    if raw:
        tabs.append(rrb.Grid(*raw, name="FMU outputs"))
    return rrb.Blueprint(rrb.Tabs(*tabs), rrb.TimePanel(timeline="sim_time"), collapse_panels=False)


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
