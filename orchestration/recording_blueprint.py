"""Default Rerun blueprints stored in the recordings (part of ``orchestration.recording``).

A single run: a "Paper figures" tab whose views reproduce section 4 of the paper (Figs 1-9) plus an
events log, and an "FMU outputs" tab with one plot per FMU instance (the raw layer). A comparison:
the runs overlaid joint by joint (Figs 10-12). Views whose entities a run lacks are left out.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import rerun.blueprint as rrb
from rerun.encodings import TimeRange, TimeRangeBoundary

if TYPE_CHECKING:
    from orchestration.recording import RunWriter

TIMELINES = ("sim_time", "step")


def _whole_run() -> rrb.archetypes.TimeAxis:
    """Time-series x axis over the whole run, as the paper's figures show it (the viewer's default
    follows the cursor with a window of the latest samples)."""
    return rrb.archetypes.TimeAxis(view_range=TimeRange(start=TimeRangeBoundary.infinite(), end=TimeRangeBoundary.infinite()))


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
    return rrb.Spatial2DView(origin="/", contents=contents, name=name, overrides=overrides)


def run_blueprint(writer: "RunWriter") -> rrb.Blueprint:
    present = {g.path for g in writer.groups}
    figures = []

    def plot(name: str, *paths: str) -> None:
        if paths[0] in present:
            figures.append(rrb.TimeSeriesView(origin="/", contents=[p for p in paths if p in present], name=name,
                                              axis_x=_whole_run()))

    plot("Figs. 1-2: critic weights W", "/controller/weights")
    plot("Fig. 3: joint 1 position phi1 vs phi1_d [rad]", "/joints/phi1")
    plot("Fig. 4: joint 2 position phi2 vs phi2_d [rad]", "/joints/phi2")
    plot("Fig. 5: tracking errors e = phi - phi_d [rad]", "/tracking/error")
    plot("Fig. 6: saturated optimal inputs tau* [N.m]", "/torques/tau_star")
    plot("Fig. 7: feedforward inputs tau^a [N.m]", "/torques/tau_a")
    plot("Fig. 8: control torques tau and the limits +-rho [N.m]", "/torques/tau", "/torques/limit")
    side = [rrb.TextLogView(origin="/events", name="Events (PE, CL, tuning law, clipping, failures)")]
    ws = _workspace_view([writer], "Fig. 9: end-effector path E (red) vs E_d (blue), arm [m]")
    if ws is not None:
        side.insert(0, ws)
    raw = [rrb.TimeSeriesView(origin=f"/fmu/{inst}", name=f"{inst}: every output", axis_x=_whole_run())
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
        overlay("Fig. 10: joint 1 tracking error e1 [rad]", "/tracking/e1"),
        overlay("Fig. 10: joint 2 tracking error e2 [rad]", "/tracking/e2"),
        overlay("Fig. 11: joint 1 torque tau1, limits +-rho [N.m]", "/torques/tau1", ["/limit"]),
        overlay("Fig. 11: joint 2 torque tau2, limits +-rho [N.m]", "/torques/tau2", ["/limit"]),
        overlay("Torque norm ||tau||, limit rho [N.m]", "/torques/norm", ["/limit"]),
    ]
    side = [rrb.TextLogView(origin="/", contents=[f"/{label}/events/**" for label in labels], name="Events")]
    ws = _workspace_view(writers, "Fig. 12: end-effector paths of " + ", ".join(labels) + " (desired in blue) [m]")
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
