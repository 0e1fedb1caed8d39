"""The default views of a run recording (issue 51): checked on the blueprint object a real run stores and
on the recording itself, read back with Rerun's own reader."""
from __future__ import annotations

import numpy as np
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

import orchestration.recording.writer as writer
from orchestration.recording.blueprint import TABS, VIEW_DESCRIPTIONS
from orchestration.recording.writer import RunRecorder
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario

STOP = 0.5  # s: a short run holds every entity a long one does


@pytest.fixture(scope="module", params=["paper", "paper-ct"])
def recorded(request, fmu_paths, tmp_path_factory):
    """A short run of the scenario, the blueprint object its recorder made, and the recording's entities."""
    made, original = [], writer.run_blueprint

    def keep(w):
        made.append(original(w))
        return made[-1]

    path = tmp_path_factory.mktemp("bp") / f"{request.param}.rrd"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(writer, "run_blueprint", keep)
        with RunRecorder(path) as rec:
            result = run(load_scenario(request.param).with_stop_time(STOP), fmu_paths, observer=rec)
    assert not result.failed and len(made) == 1
    entities = {chunk.entity_path for chunk in RrdReader(path).stream().to_chunks()}
    return request.param, made[0], path, entities


def walk(part, containers: list, views: list) -> None:
    if isinstance(part, rrb.Container):
        containers.append(part)
        for sub in part.contents:
            walk(sub, containers, views)
    else:
        views.append(part)


def parts(blueprint: rrb.Blueprint) -> tuple[list[rrb.Container], list[rrb.View]]:
    containers, views = [], []
    walk(blueprint.root_container, containers, views)
    return containers, views


def queried(view: rrb.View) -> list[str]:
    """The entity paths a view names: its contents (``$origin`` resolved) and its per-entity overrides."""
    contents = [view.contents] if isinstance(view.contents, str) else list(view.contents)
    return [str(c).replace("$origin", str(view.origin).rstrip("/")) for c in contents] + list(view.visualizer_overrides)


def batch(component) -> list:
    return component.as_arrow_array().to_pylist()


def test_every_container_holds_something_and_no_grid_has_an_empty_cell(recorded):
    _, blueprint, _, _ = recorded
    containers, _ = parts(blueprint)
    for c in containers:
        assert c.contents, (c.kind, c.name)
        if c.kind == rrb.components.ContainerKind.Grid:
            # without a column count Rerun picks one (3 x 3 for 8 views: one cell empty)
            assert c.grid_columns and len(c.contents) % c.grid_columns == 0, (c.name, len(c.contents), c.grid_columns)
    tabs = blueprint.root_container
    assert tabs.kind == rrb.components.ContainerKind.Tabs
    assert [t.name for t in tabs.contents] == list(TABS)  # the FMU outputs tab is kept


def test_every_view_names_entities_the_recording_holds(recorded):
    _, blueprint, _, entities = recorded
    for view in parts(blueprint)[1]:
        for query in queried(view):
            if query.endswith("/**"):
                root = query[:-3]
                assert any(e == root or e.startswith(root + "/") for e in entities), (view.name, query)
            else:
                assert query in entities, (view.name, query)


def test_every_time_series_legend_has_its_corner_and_visibility_off_the_data(recorded):
    """The legend sits at the right top, in the strip that each time axis keeps right of its data."""
    name, blueprint, path, _ = recorded
    scenario = load_scenario(name).with_stop_time(STOP)
    series = [v for v in parts(blueprint)[1] if isinstance(v, rrb.TimeSeriesView)]
    assert series
    stored = {}
    (bp,) = RrdReader(path).blueprints()
    for chunk in RrdReader(path).stream(store=bp).to_chunks():
        rb = chunk.to_record_batch()
        stored.setdefault(chunk.entity_path, {}).update({n: rb.column(n).to_pylist()[-1] for n in rb.schema.names
                                                         if n.startswith("PlotLegend:")})
    for view in series:
        legend = view.properties["PlotLegend"]
        assert batch(legend.corner) == [rrb.components.Corner2D.RightTop.value] and batch(legend.visible) == [True], view.name
        in_file = stored[f"/view/{view.id}/PlotLegend"]  # the file holds this very blueprint
        assert in_file["PlotLegend:corner"] == [rrb.components.Corner2D.RightTop.value] and in_file["PlotLegend:visible"] == [True]
        (axis,) = batch(view.properties["TimeAxis"].view_range)
        shown = scenario.stop_time * 1e9
        if "VisibleTimeRanges" in view.properties:  # the first seconds: only 0 .. window on sim_time
            (window,) = [r["range"] for r in batch(view.properties["VisibleTimeRanges"].ranges) if r["timeline"] == "sim_time"]
            assert window["start"] == 0 and window["end"] <= 5e9, view.name
            shown = window["end"]
        assert axis["start"] == 0 and axis["end"] >= 1.15 * shown, view.name  # room for the legend


def test_the_first_seconds_have_views_of_their_own(recorded):
    name, blueprint, _, _ = recorded
    first = next(t for t in blueprint.root_container.contents if t.name == "First seconds")
    containers, views = [], []
    walk(first, containers, views)
    titles = {v.name for v in views}
    assert {"e, 0-5 s", "tau, 0-5 s", "Events"} <= titles
    if name == "paper":  # the SOTC's learning, PE and feedforward
        assert {"W, 0-5 s", "tau^a, 0-5 s", "tau*, 0-1 s", "PE, 0-1 s"} <= titles
    assert titles <= set(VIEW_DESCRIPTIONS) and max(map(len, titles)) <= 16


def test_the_path_view_has_axes_a_base_and_a_legend(recorded):
    name, blueprint, path, _ = recorded
    from support.rrd_contents import statics

    (fig9,) = [v for v in parts(blueprint)[1] if v.name == "Fig. 9: path"]
    assert "/workspace/frame/**" in queried(fig9)
    frame = statics(path)
    assert frame["/workspace/frame/base"]["Points2D:positions"] == [[[0.0, 0.0]]]
    assert frame["/workspace/frame/base"]["Points2D:labels"] == [["base (0, 0)"]]
    ticks = frame["/workspace/frame/ticks"]["Points2D:labels"][0]
    assert {"0.5", "1", "1.5", "2", "X [m]", "Y [m]"} <= set(ticks)
    legend = frame["/workspace/frame/legend/labels"]["Points2D:labels"][0]
    assert legend == ["E: actual path", "arm at the time cursor", "E_d: desired path (47)"]
    colours = np.array(frame["/workspace/frame/legend"]["LineStrips2D:colors"][0], dtype=np.uint32)
    assert len(colours) == 3 and len(set(colours.tolist())) == 3  # one colour per entry
