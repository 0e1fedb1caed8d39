"""The default views of a run recording and of a comparison's (issue 51): checked on the blueprint object a
real run (or ``record_comparison``) stores and on the recording itself, read back with Rerun's own reader."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

import orchestration.recording.overlays as overlays
import orchestration.recording.writer as writer
from orchestration.recording.blueprint import COMPARE_TABS, TABS, VIEW_DESCRIPTIONS
from orchestration.recording.writer import RunRecorder
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario

STOP = 0.5  # s: a short run holds every entity a long one does
COMPARED = ("paper", "paper-ct")  # the SOTC and a controller without its weights, PE and feedforward


def _keeping(module, name: str, mp: pytest.MonkeyPatch) -> list:
    """Has ``module.name`` (a blueprint function) keep every blueprint it makes in the returned list."""
    made, original = [], getattr(module, name)

    def keep(*args):
        made.append(original(*args))
        return made[-1]

    mp.setattr(module, name, keep)
    return made


@pytest.fixture(scope="module", params=["paper", "paper-ct", "compare"])
def recorded(request, fmu_paths, tmp_path_factory):
    """A short run of the scenario (or a comparison of ``COMPARED``), the blueprint object its recorder
    made, the recording and its entities."""
    path = tmp_path_factory.mktemp("bp") / f"{request.param}.rrd"
    with pytest.MonkeyPatch.context() as mp:
        if request.param == "compare":
            made = _keeping(overlays, "comparison_blueprint", mp)
            results = [run(load_scenario(name).with_stop_time(STOP), fmu_paths) for name in COMPARED]
            overlays.record_comparison(results, path)
        else:
            made = _keeping(writer, "run_blueprint", mp)
            with RunRecorder(path) as rec:
                results = [run(load_scenario(request.param).with_stop_time(STOP), fmu_paths, observer=rec)]
    assert not any(r.failed for r in results) and len(made) == 1
    entities = {chunk.entity_path for chunk in RrdReader(path).stream().to_chunks()}
    return SimpleNamespace(name=request.param, blueprint=made[0], path=path, entities=entities)


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
    containers, _ = parts(recorded.blueprint)
    for c in containers:
        assert c.contents, (c.kind, c.name)
        if c.kind == rrb.components.ContainerKind.Grid:
            # without a column count Rerun picks one (3 x 3 for 8 views: one cell empty)
            assert c.grid_columns and len(c.contents) % c.grid_columns == 0, (c.name, len(c.contents), c.grid_columns)
    tabs = recorded.blueprint.root_container
    assert tabs.kind == rrb.components.ContainerKind.Tabs
    # a run keeps its FMU outputs tab; a comparison has Figs 10-11, Fig. 12 and the first seconds
    assert [t.name for t in tabs.contents] == list(COMPARE_TABS if recorded.name == "compare" else TABS)


def test_every_view_names_entities_the_recording_holds(recorded):
    for view in parts(recorded.blueprint)[1]:
        for query in queried(view):
            if query.endswith("/**"):
                root = query[:-3]
                assert any(e == root or e.startswith(root + "/") for e in recorded.entities), (view.name, query)
            else:
                assert query in recorded.entities, (view.name, query)


def test_every_time_series_legend_has_its_corner_and_visibility_off_the_data(recorded):
    """The legend sits at the right top, in the strip that each time axis keeps right of its data."""
    series = [v for v in parts(recorded.blueprint)[1] if isinstance(v, rrb.TimeSeriesView)]
    assert series
    stored = {}
    (bp,) = RrdReader(recorded.path).blueprints()
    for chunk in RrdReader(recorded.path).stream(store=bp).to_chunks():
        rb = chunk.to_record_batch()
        stored.setdefault(chunk.entity_path, {}).update({n: rb.column(n).to_pylist()[-1] for n in rb.schema.names
                                                         if n.startswith("PlotLegend:")})
    for view in series:
        legend = view.properties["PlotLegend"]
        assert batch(legend.corner) == [rrb.components.Corner2D.RightTop.value] and batch(legend.visible) == [True], view.name
        in_file = stored[f"/view/{view.id}/PlotLegend"]  # the file holds this very blueprint
        assert in_file["PlotLegend:corner"] == [rrb.components.Corner2D.RightTop.value] and in_file["PlotLegend:visible"] == [True]
        (axis,) = batch(view.properties["TimeAxis"].view_range)
        shown = STOP * 1e9
        if "VisibleTimeRanges" in view.properties:  # the first seconds: only 0 .. window on sim_time
            (window,) = [r["range"] for r in batch(view.properties["VisibleTimeRanges"].ranges) if r["timeline"] == "sim_time"]
            assert window["start"] == 0 and window["end"] <= 5e9, view.name
            shown = window["end"]
        assert axis["start"] == 0 and axis["end"] >= 1.15 * shown, view.name  # room for the legend
        if recorded.name == "compare" and not view.name.startswith("||tau||"):  # two views a row
            # a comparison's legends name the runs: "paper-ct: ||tau|| [N.m]" takes about 175 px of the
            # 740 px that a view plots in, two views to a 1600 px row
            assert axis["end"] >= 1.3 * shown, view.name


def test_every_curve_has_a_name(recorded):
    """What a legend lists: each series a time-series view shows is named (the runs' label in a comparison)."""
    names = {}
    for chunk in RrdReader(recorded.path).stream().to_chunks():
        rb = chunk.to_record_batch()
        if "SeriesLines:names" in rb.schema.names:
            names[chunk.entity_path] = rb.column("SeriesLines:names").to_pylist()[-1]
    for view in parts(recorded.blueprint)[1]:
        if isinstance(view, rrb.TimeSeriesView) and view.origin == "/":
            for entity in queried(view):
                assert names.get(entity) and all(names[entity]), (view.name, entity)
    if recorded.name == "compare":
        assert names["/paper/tracking/e1"] == ["paper: e1 [rad]"] and names["/paper-ct/torques/norm"] == ["paper-ct: ||tau|| [N.m]"]


def test_the_first_seconds_have_views_of_their_own(recorded):
    first = next(t for t in recorded.blueprint.root_container.contents if t.name == "First seconds")
    containers, views = [], []
    walk(first, containers, views)
    titles = {v.name for v in views}
    if recorded.name == "compare":
        assert titles == {"e1, 0-5 s", "e2, 0-5 s", "tau1, 0-5 s", "tau2, 0-5 s", "||tau||, 0-5 s"}
    else:
        assert {"e, 0-5 s", "tau, 0-5 s", "Events"} <= titles
    if recorded.name == "paper":  # the SOTC's learning, PE and feedforward
        assert {"W, 0-5 s", "tau^a, 0-5 s", "tau*, 0-1 s", "PE, 0-1 s"} <= titles
    assert titles <= set(VIEW_DESCRIPTIONS) and max(map(len, titles)) <= 16


def test_the_events_show_time_level_and_a_text_that_names_the_run(recorded):
    """The viewer cuts the entity path short: a comparison's texts begin with their run's name instead."""
    from support.rrd_contents import read_entities

    (events,) = [v for v in parts(recorded.blueprint)[1] if v.name == "Events"]
    columns = [(rrb.encodings.TextLogColumnKind(c["kind"]).name, c["visible"])
               for c in batch(events.properties["TextLogColumns"].text_log_columns)]
    assert columns == [("LogLevel", True), ("Body", True), ("EntityPath", False)]
    texts = {e: [t for (t,) in v["TextLog:text"]] for e, v in read_entities(recorded.path).items() if "/events/" in e}
    if recorded.name == "compare":
        assert {e.split("/events/")[0].strip("/") for e in texts} == set(COMPARED)
        for entity, lines in texts.items():
            run = entity.split("/events/")[0].strip("/")
            assert all(t.startswith(f"{run}: ") for t in lines), (entity, lines[:2])
    else:
        assert texts["/events/run"][0].startswith("run finished: ")  # a single run's texts name no run


def test_the_path_view_has_axes_a_base_and_a_legend(recorded):
    from support.rrd_contents import statics

    title = "Fig. 12: paths" if recorded.name == "compare" else "Fig. 9: path"
    (view,) = [v for v in parts(recorded.blueprint)[1] if v.name == title]
    assert "/workspace/frame/**" in queried(view)
    frame = statics(recorded.path)
    assert frame["/workspace/frame/base"]["Points2D:positions"] == [[[0.0, 0.0]]]
    assert frame["/workspace/frame/base"]["Points2D:labels"] == [["base (0, 0)"]]
    ticks = frame["/workspace/frame/ticks"]["Points2D:labels"][0]
    assert {"0.5", "1", "1.5", "2", "X [m]", "Y [m]"} <= set(ticks)
    legend = frame["/workspace/frame/legend/labels"]["Points2D:labels"][0]
    run_legend = ["E: actual path", "arm at the time cursor"]
    assert legend == (list(COMPARED) if recorded.name == "compare" else run_legend) + ["E_d: desired path (47)"]
    colours = np.array(frame["/workspace/frame/legend"]["LineStrips2D:colors"][0], dtype=np.uint32)
    assert len(colours) == 3 and len(set(colours.tolist())) == 3  # one colour per entry
