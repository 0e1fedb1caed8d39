"""Sweep files: parsing, validation before anything runs, combinations, seeded random axes, the
shipped sweeps, the tables and the per-point task (divergence, refusals) in this process."""
import json
import math

import numpy as np
import pytest

from orchestration.cli import main
from orchestration.sweep.results import doc_block, summary_markdown, table_csv
from orchestration.sweep.runner import PointGuard, point_key, run_point
from orchestration.sweep.spec import load_sweep, parse_sweep
from support import REPO

BASE = {"scenario": "paper-ct", "stop_time": 1.0}


def sweep_of(**raw):
    return parse_sweep({**BASE, **raw}, "test")


def test_grid_is_the_cartesian_product_in_file_order_last_axis_fastest():
    s = sweep_of(axis=[{"name": "controller.kp", "values": [1, 2]}, {"name": "plant.f1", "values": [8, 9, 10]}])
    pts = s.points()
    assert [p.settings for p in pts][:4] == [
        {"controller.kp": 1.0, "plant.f1": 8.0}, {"controller.kp": 1.0, "plant.f1": 9.0},
        {"controller.kp": 1.0, "plant.f1": 10.0}, {"controller.kp": 2.0, "plant.f1": 8.0}]
    assert len(pts) == 6 and pts[4].scenario.instances["plant"].parameters["f1"] == 9.0
    assert pts[4].scenario.instances["controller"].parameters["kp"] == 2.0
    assert s.base.instances["controller"].parameters == {}  # the base is untouched


def test_paired_groups_and_one_at_a_time():
    axes = [{"name": "plant.phi1_0", "values": [0.1, 0.2], "group": "x0"},
            {"name": "plant.phi2_0", "values": [-0.1, -0.2], "group": "x0"},
            {"name": "step_size", "values": [0.005, 0.02]}]
    paired = sweep_of(combine="paired", axis=axes).points()
    assert [p.settings for p in paired] == [
        {"plant.phi1_0": 0.1, "plant.phi2_0": -0.1, "step_size": 0.005},
        {"plant.phi1_0": 0.2, "plant.phi2_0": -0.2, "step_size": 0.02}]
    assert paired[1].scenario.step_size == 0.02 and paired[1].scenario.steps == 50
    oat = sweep_of(combine="one-at-a-time", axis=axes).points()
    assert [p.settings for p in oat] == [
        {"plant.phi1_0": 0.1, "plant.phi2_0": -0.1}, {"plant.phi1_0": 0.2, "plant.phi2_0": -0.2},
        {"step_size": 0.005}, {"step_size": 0.02}]
    assert oat[2].scenario.instances["plant"].parameters["phi1_0"] == 0.5  # the others stay at the base


def test_scaled_axis_multiplies_the_base_value_and_controller_axis_swaps_the_fmu():
    s = parse_sweep({"scenario": "paper-perturbed", "stop_time": 1.0, "set": {"noise.seed": 3}, "axis": [
        {"name": "controller", "values": ["SotcController", "CtController"]},
        {"name": "plant.p1", "values": [0.8], "scale": True}]}, "test")
    sotc, ct = s.points()
    assert sotc.settings == {"controller": "SotcController", "plant.p1 [x base]": 0.8}
    assert sotc.scenario.instances["plant"].parameters["p1"] == pytest.approx(0.8 * 3.473)
    assert sotc.scenario.instances["controller"].parameters["alpha1"] == 50.0  # same FMU: keeps its tuning
    assert ct.scenario.instances["controller"].fmu == "CtController"
    assert ct.scenario.instances["controller"].parameters == {}  # another FMU starts from its defaults
    assert ct.scenario.instances["noise"].parameters["seed"] == 3  # `set` reaches every point
    assert s.model_names() == sorted({"ArmPlant", "ReferenceTrajectory", "SotcController", "CtController",
                                      "Disturbance", "MeasurementNoise"})


CONTROLLERS = {"scenario": "paper-perturbed", "stop_time": 1.0, "set": {"controller.limit_handling": 2}, "axis": [
    {"name": "controller", "values": ["SotcController", "CtController", "LqrController", "OtcController"]}]}


def test_controller_settings_reach_only_the_points_of_that_controller():
    s = parse_sweep({**CONTROLLERS, "controller_settings": {
        "LqrController": {"controller.q": 100, "controller.r": 0.01},
        "OtcController": {"controller.limit_handling": 3}}}, "test")
    sotc, ct, lqr, otc = (p.scenario.instances["controller"].parameters for p in s.points())
    assert lqr == {"limit_handling": 2, "q": 100.0, "r": 0.01}
    assert ct == {"limit_handling": 2} and "q" not in sotc and sotc["alpha1"] == 50.0
    assert otc == {"limit_handling": 3}  # the controller's own setting wins over `set`
    assert s.points()[2].settings == {"controller": "LqrController", "controller.q": 100.0, "controller.r": 0.01}
    assert s.points()[1].settings == {"controller": "CtController"}
    md = summary_markdown(s, [], 4)
    assert ("Per controller (`controller_settings`): LqrController: `controller.q = 100`, `controller.r = 0.01`; "
            "OtcController: `controller.limit_handling = 3`.") in md


def test_tuning_best_asks_the_tuning_protocol_under_each_points_limit_handling(monkeypatch):
    """Every controller, the SOTC and the OTC included, can ask for its tuned parameters."""
    from orchestration.study import tuning

    asked = []

    def tuned_parameters(fmu, handling, seed=None):  # stands in for the stored search
        asked.append((fmu, handling) if seed is None else (fmu, handling, seed))
        return {name: 10.0 * handling + 1 for name in sorted(tuning.tuned_parameter_names(fmu))[:1]}

    monkeypatch.setattr(tuning, "tuned_parameters", tuned_parameters)
    tuned = {fmu: {"tuning": "best"} for fmu in tuning.CONTROLLERS}
    s = parse_sweep({**CONTROLLERS, "controller_settings": tuned}, "test")
    sotc, ct, lqr, otc = s.points()
    assert ct.scenario.instances["controller"].parameters == {"limit_handling": 2, "kd": 21.0}
    assert sotc.settings["controller.alpha1"] == 21.0 and otc.settings["controller.lambda1"] == 21.0
    assert set(asked) == {(fmu, 2) for fmu in tuning.CONTROLLERS}
    # without `set`, each FMU's default handling (radial for CT and LQR); one given in the table counts
    s = parse_sweep({**CONTROLLERS, "set": {}, "controller_settings": {
        "CtController": {"tuning": "best"}, "LqrController": {"tuning": "best", "controller.limit_handling": 1}}}, "test")
    _, ct, lqr, _ = s.points()
    assert ct.settings == {"controller": "CtController", "controller.kd": 1.0}
    assert lqr.scenario.instances["controller"].parameters == {"limit_handling": 1, "q": 11.0}
    assert {("CtController", 0), ("LqrController", 1)} <= set(asked)
    # a tuning seed other than the first, named in the table
    seed = tuning.stored()["seeds"][-1]
    s = parse_sweep({**CONTROLLERS, "controller_settings": {"CtController": {"tuning": "best", "tuning_seed": seed}}}, "test")
    s.points()
    assert ("CtController", 2, seed) in asked


@pytest.mark.parametrize("settings, message", [
    ({"PidController": {"controller.kp": 1.0}}, "controller_settings.PidController: no point of this sweep runs"),
    ({"LqrController": {"controller.q": math.nan}}, 'controller_settings.LqrController."controller.q": nan is not finite'),
    ({"LqrController": {"controller.r": math.inf}}, 'controller_settings.LqrController."controller.r": inf is not finite'),
    ({"LqrController": {"controller.r": "small"}}, "'small' is not a number"),
    ({"LqrController": {"controller.q": -1.0}}, "'q': -1 is outside the valid range"),
    ({"LqrController": {"controller.kp": 1.0}}, "LqrController has no parameter 'kp'"),
    ({"LqrController": {"nosuch.q": 1.0}}, '"nosuch.q": write instance.parameter'),
    ({"OtcController": {"tuning": "best", "controller.q": 2.0}}, "sets controller.q already"),
    ({"SotcController": {"tuning": "best", "controller.alpha1": 3.0}}, "sets controller.alpha1 already"),
    ({"CtController": {"tuning": "fastest"}}, "CtController.tuning: 'fastest' is not one of ['best']"),
    ({"CtController": {"tuning": "best", "controller.kp": 9.0}}, "tuning = 'best' sets controller.kp already"),
    ({"CtController": 3}, "controller_settings.CtController: 3 is not a table"),
    ({"CtController": {"tuning_seed": 0}}, 'tuning_seed = 0: with tuning = "best"'),
    ({"CtController": {"tuning": "best", "tuning_seed": 99}}, "one of the stored tuning seeds"),
    ({"CtController": {"tuning": "best", "tuning_seed": True}}, "tuning_seed: True is not a whole number"),
])
def test_bad_controller_settings_are_refused_with_the_key_named(settings, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace("[", r"\[")):
        parse_sweep({**CONTROLLERS, "controller_settings": settings}, "test")


def test_controller_settings_may_not_set_what_an_axis_varies():
    raw = {**CONTROLLERS, "axis": [*CONTROLLERS["axis"], {"name": "controller.kd", "values": [1.0, 2.0]}]}
    with pytest.raises(ValueError, match='CtController."controller.kd": an axis varies controller.kd already'):
        parse_sweep({**raw, "controller_settings": {"CtController": {"controller.kd": 5.0}}}, "test")


def test_a_bad_controller_setting_exits_2_before_anything_runs(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('scenario = "paper-perturbed"\n[controller_settings.SotcController]\n"controller.alpha1" = nan\n')
    assert main(["sweep", str(bad), "--out", str(tmp_path / "out")]) == 2
    assert 'controller_settings.SotcController."controller.alpha1": nan is not finite' in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_random_axes_are_seeded():
    spec = {"name": "plant.f1", "random": {"distribution": "uniform", "low": 5, "high": 10, "count": 5}}
    a, b = sweep_of(seed=4, axis=[spec]), sweep_of(seed=4, axis=[spec])
    c = sweep_of(seed=5, axis=[spec])
    assert a.axes[0].values == b.axes[0].values != c.axes[0].values
    assert all(5 <= v < 10 for v in a.axes[0].values) and len(set(a.axes[0].values)) == 5
    log = sweep_of(axis=[{"name": "plant.f1", "random": {"distribution": "loguniform", "low": 1, "high": 100, "count": 50}}])
    assert all(1 <= v <= 100 for v in log.axes[0].values)
    pick = sweep_of(axis=[{"name": "step_size", "random": {"distribution": "choice", "values": [0.005, 0.01], "count": 6}}])
    assert set(pick.axes[0].values) <= {0.005, 0.01}


@pytest.mark.parametrize("axis, message", [
    ({"name": "plant.f1", "values": [1.0, math.nan]}, "axis 'plant.f1': values[1]: nan is not finite"),
    ({"name": "plant.f1", "values": [1.0, math.inf]}, "axis 'plant.f1': values[1]: inf is not finite"),
    ({"name": "plant.f1", "values": [1.0, "fast"]}, "axis 'plant.f1': values[1]: 'fast' is not a number"),
    ({"name": "plant.f1", "values": [True]}, "axis 'plant.f1': values[0]: True is not a number"),
    ({"name": "plant.f1", "range": {"start": 0, "stop": math.nan, "num": 3}}, "axis 'plant.f1': range.stop"),
    ({"name": "plant.f1", "random": {"distribution": "normal", "mean": 1, "std": math.inf, "count": 3}}, "random.std"),
    ({"name": "plant.f1", "random": {"distribution": "cauchy", "count": 3}}, "random.distribution: 'cauchy' is not one of ['uniform', 'normal', 'loguniform', 'choice']"),
    ({"name": "nosuch.kp", "values": [1.0]}, "axis 'nosuch.kp'"),
    ({"name": "controller", "values": [1.0]}, "axis 'controller'"),
    ({"name": "plant.f1", "values": [1.0], "scale": True}, "does not set plant.f1"),
    ({"name": "plant.f1", "values": [1.0], "step": 2}, "unknown keys"),
    ({"name": "step_size", "values": [0.03]}, "whole number of steps"),
])
def test_bad_axes_are_refused_before_anything_runs_with_the_axis_named(axis, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace("[", r"\[")):
        sweep_of(axis=[axis])


def test_bad_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="paired"):
        sweep_of(combine="paired", axis=[{"name": "plant.f1", "values": [1.0, 2.0]}, {"name": "plant.f2", "values": [1.0]}])
    with pytest.raises(ValueError, match='set."plant.f1": nan is not finite'):
        sweep_of(set={"plant.f1": math.nan})
    with pytest.raises(ValueError, match="time_limit"):
        sweep_of(time_limit=-1)
    with pytest.raises(ValueError, match="no sweep 'nosuch'.*robustness"):
        load_sweep("nosuch")
    bad = tmp_path / "bad.toml"
    bad.write_text('scenario = "paper-ct"\n[[axis]]\nname = "plant.f1"\nvalues = [1.0, nan]\n')
    code = main(["sweep", str(bad)])
    assert code == 2  # one line, nothing ran


def test_shipped_sweeps_load():
    sizes = {name: len(load_sweep(name).points()) for name in ("robustness", "learning", "controllers")}
    assert sizes == {"robustness": 41, "learning": 24, "controllers": 80}
    controllers = load_sweep("controllers")
    pts = controllers.points()
    # every controller sees the same perturbed plants from the same initial states
    by_ctrl = {}
    for p in pts:
        plant = {k: v for k, v in p.settings.items() if k.partition(".")[0] != "controller"}
        by_ctrl.setdefault(p.settings["controller"], []).append(plant)
    first, *others = by_ctrl.values()
    assert len(by_ctrl) == 5 and all(o == first for o in others)
    # the same tuning effort: every controller runs the best point of the one tuning protocol under the sweep's handling
    from orchestration.study.tuning import tuned_parameters

    handling = controllers.fixed["controller.limit_handling"]
    for p in pts:
        params, fmu = p.scenario.instances["controller"].parameters, p.scenario.controller_fmu()
        best = tuned_parameters(fmu, handling)
        if p.settings["controller"] == "SOTC, learning off":  # the same design, its critic frozen after the tuning
            assert fmu == "SotcController" and params["alpha1"] == params["alpha2"] == 1e-9
            best = {k: v for k, v in best.items() if k not in ("alpha1", "alpha2")}
        assert {k: params[k] for k in best} == best


def test_named_controller_entries(tmp_path):
    """A named entry runs its FMU under its own label; learning = false only where the FMU learns."""
    s = sweep_of(scenario="paper", axis=[{"name": "controller", "values": ["SotcController", "frozen"]}],
                 controller_settings={"frozen": {"fmu": "SotcController", "learning": False, "controller.lambda1_1": 2.0}})
    on, off = s.points()
    assert off.scenario.controller_fmu() == "SotcController" and off.settings["controller"] == "frozen"
    assert off.scenario.instances["controller"].parameters["alpha1"] == 1e-9 and off.settings["controller.lambda1_1"] == 2.0
    assert on.scenario.instances["controller"].parameters["alpha1"] != 1e-9
    assert s.model_names().count("SotcController") == 1
    with pytest.raises(ValueError, match="learning = False"):
        sweep_of(axis=[{"name": "controller", "values": ["CtController"]}],
                 controller_settings={"CtController": {"learning": False}})
    with pytest.raises(ValueError, match="fmu = 'Nope'"):
        sweep_of(axis=[{"name": "controller", "values": ["x"]}], controller_settings={"x": {"fmu": "Nope"}})


def test_point_key_changes_with_the_scenario_and_the_fmu_digest():
    s = sweep_of(axis=[{"name": "controller.kp", "values": [1, 2]}])
    a, b = s.points()
    digests = {m: "0" * 64 for m in s.model_names()}
    assert point_key(a.scenario, digests) == point_key(a.scenario, dict(digests))
    assert point_key(a.scenario, digests) != point_key(b.scenario, digests)
    assert point_key(a.scenario, digests) != point_key(a.scenario, {**digests, "CtController": "1" * 64})


def _rows(sweep):
    rows = []
    for p in sweep.points():
        ok = p.index != 1
        rows.append({"index": p.index, "key": f"{p.index:016d}" + "0" * 48, "settings": p.settings,
                     "status": "ok" if ok else "failed", "reason": None if ok else "time limit of 5 s exceeded",
                     "summary": {"controller": "CtController", "mse": [0.1 * (p.index + 1), 0.2],
                                 "max_abs_error_last_half": [0.01 * (p.index + 1), 0.02], "max_norm_tau": 3.5,
                                 "samples_over_limit": 0}})
    return rows


def test_table_and_summary_are_written_from_the_rows():
    s = sweep_of(axis=[{"name": "controller.kp", "values": [1, 2, 3]}])
    rows = _rows(s)
    lines = table_csv(s, rows).splitlines()
    assert lines[0].startswith("index,key,controller.kp,status,reason,mse_1")
    assert lines[1].startswith("0,0000000000000000,1.0,ok,,0.1,0.2,0.01,0.02,3.5,0")
    assert lines[2] == "1,0000000000000001,2.0,failed,time limit of 5 s exceeded,,,,,,"  # no partial metrics
    md = summary_markdown(s, rows, total=3)
    assert "| 3 | - | 1 | 0 | 0.03 | 0 | 0.03 | 3.5 | 0 |" in md
    assert "| 2 | - | 1 | 1 | - |" in md and "time limit of 5 s exceeded" in md


def test_tail_errors_are_paired_by_the_points_other_settings():
    from orchestration.sweep.results import paired_tail_errors

    def row(ctrl, f1, e, status="ok", **tuned):
        return {"settings": {"controller": ctrl, "plant.f1": f1, **tuned}, "status": status,
                "summary": {"controller": ctrl, "max_abs_error_last_half": [e, e / 2]}}

    rows = [row("SotcController", 8.0, 0.05), row("SotcController", 9.0, 0.06),
            row("CtController", 9.0, 0.01, **{"controller.kp": 100.0}), row("CtController", 8.0, 0.2, status="failed")]
    assert paired_tail_errors(rows) == {"SotcController": {(("plant.f1", 8.0),): 0.05, (("plant.f1", 9.0),): 0.06},
                                        "CtController": {(("plant.f1", 9.0),): 0.01, (("plant.f1", 8.0),): None}}


def test_doc_block_replaces_only_its_own_block():
    from orchestration.reports.docgen import replace_block

    s = sweep_of(name="tiny", axis=[{"name": "controller.kp", "values": [1, 2, 3]}])
    block = doc_block(s, _rows(s), 3, ["sweeps/tiny/controller.kp.png"])
    text = replace_block("# Doc\n\nintro\n", "sweep-tiny", block)
    assert text.startswith("# Doc\n\nintro\n\n<!-- BEGIN generated:sweep-tiny -->\n### Sweep `tiny`")
    assert "![controller.kp](sweeps/tiny/controller.kp.png)" in text
    again = replace_block(text + "\nafter\n", "sweep-tiny", block.replace("3.5", "9.9"))
    assert again.count("<!-- BEGIN") == 1 and again.endswith("\nafter\n") and "9.9" in again


def test_a_diverging_point_and_a_refused_point_are_failed_rows(fmu_dir):
    from orchestration.sweep.runner import fmu_blobs

    s = sweep_of(state_bound=0.3, axis=[{"name": "controller.kp", "values": [25.0, -1.0]}])
    blobs = fmu_blobs(s.model_names(), fmu_dir)
    digests = {m: d for m, (d, _) in blobs.items()}
    task = {"time_limit": 60.0, "state_bound": s.state_bound, "record": False}
    diverged, refused = (run_point({**task, "point": p, "key": point_key(p.scenario, digests)}, blobs) for p in s.points())
    assert diverged["status"] == "failed" and diverged["reason"].startswith("diverged: plant.")
    assert "beyond the bound 0.3" in diverged["reason"]
    assert refused["status"] == "failed" and "'kp'" in refused["reason"]
    assert diverged["trace"].shape[1] == 3  # the samples up to the bound, for the sweep recording


def test_guard_keeps_every_stride_th_sample_across_blocks():
    g = PointGuard(time_limit=60, state_bound=1e9, stride=3)
    cols = {"plant": ["phi1", "phi2"], "reference": ["phi1_d", "phi2_d"]}

    class Sc:
        step_size = 0.01

    g.start(Sc, cols, {})
    t = np.arange(10) * 0.01
    for lo, hi in ((0, 4), (4, 10)):
        g.block(t[lo:hi], {"plant": np.column_stack([t[lo:hi], -t[lo:hi]]), "reference": np.zeros((hi - lo, 2))})
    trace = np.concatenate(g.trace)
    assert np.allclose(trace[:, 0], t[::3]) and np.allclose(trace[:, 1], t[::3]) and np.allclose(trace[:, 2], -t[::3])


def test_an_existing_scheduler_gets_the_fmus_with_the_tasks(fmu_dir, tmp_path):
    from distributed import LocalCluster

    (tmp_path / "s.toml").write_text('scenario = "paper-ct"\nstop_time = 0.5\n[[axis]]\nname = "controller.kp"\n'
                                     'values = [25.0, 100.0]\n')
    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        code = main(["sweep", str(tmp_path / "s.toml"), "--scheduler", cluster.scheduler_address,
                     "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)])
    assert code == 0
    lines = (tmp_path / "out" / "points.csv").read_text().splitlines()
    assert [line.split(",")[2:4] for line in lines[1:]] == [["25.0", "ok"], ["100.0", "ok"]]


class _Terminal:
    def __init__(self):
        self.text = ""

    def isatty(self):
        return True

    def write(self, s):
        self.text += s

    def flush(self):
        pass


def test_progress_is_a_bar_on_a_terminal_and_plain_lines_otherwise(capsys):
    from orchestration.progress import Progress

    term = _Terminal()
    bar = Progress(4, "sweep x", workers=2, skipped=1, skipped_failed=1, stream=term)
    bar.update(True)
    bar.update(False)
    bar.close()
    assert "sweep x" in term.text and "3/4" in term.text and "failed 2" in term.text
    plain = Progress(3, "reproduce")
    plain.update(True, "paper ok")
    plain.update(False, "paper-ct FAILED")
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("reproduce: 1/3 done, 0 failed, 1 running, about ") and out[0].endswith("| paper ok")
    assert out[1].startswith("reproduce: 2/3 done, 1 failed, 1 running")


def test_set_makes_a_grid_over_a_scenario_without_a_sweep_file(fmu_dir, tmp_path, monkeypatch, capsys):
    from orchestration.sweep.spec import grid_from_assignments

    s = grid_from_assignments("paper-ct", ["controller.kp=25,100", "plant.f1=8,9"])
    assert s.name == "paper-ct-sweep" and [p.settings for p in s.points()][1] == {"controller.kp": 25.0, "plant.f1": 9.0}
    for bad, message in (("kp=1", "instance.parameter"), ("controller.kp=a,b", "must be a number"),
                         ("controller.kp=", "write instance.parameter"), ("controller.kp=1,nan", "nan is not finite")):
        with pytest.raises(ValueError, match=message):
            grid_from_assignments("paper-ct", [bad])
    monkeypatch.chdir(tmp_path)
    # a value outside its declared range is refused before anything runs
    assert main(["sweep", "paper-ct", "--set", "controller.kp=25,-1", "--workers", "1", "--fmu-dir", str(fmu_dir)]) == 2
    assert "'kp' = -1.0 is outside its valid range" in capsys.readouterr().err
    assert not (tmp_path / "recordings" / "paper-ct-sweep" / "points.csv").exists()
    # inside the range, p3 = 1 makes the plant singular: the FMU refuses it, the point fails, the other runs
    code = main(["sweep", "paper-ct", "--set", "plant.p3=0.242,1", "--workers", "1", "--fmu-dir", str(fmu_dir)])
    assert code == 1  # one point failed
    lines = (tmp_path / "recordings" / "paper-ct-sweep" / "points.csv").read_text().splitlines()
    assert [line.split(",")[2:4] for line in lines[1:]] == [["0.242", "ok"], ["1.0", "failed"]]
    capsys.readouterr()
    # --retry-failed runs the failed point again and keeps the finished one
    code = main(["sweep", "paper-ct", "--set", "plant.p3=0.242,1", "--workers", "1", "--retry-failed",
                 "--fmu-dir", str(fmu_dir)])
    assert code == 1 and "2 points, 1 already in" in capsys.readouterr().out
    jsonl = (tmp_path / "recordings" / "paper-ct-sweep" / "points.jsonl").read_text().splitlines()
    assert len(jsonl) == 3  # the failed point has a second line; the last line of a key wins


def test_stop_time_option_sets_the_base_scenario(fmu_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "short"
    assert main(["sweep", "paper-ct", "--set", "controller.kp=25,50", "--stop-time", "0.2", "--workers", "1",
                 "--out", str(out), "--fmu-dir", str(fmu_dir)]) == 0
    rows = [json.loads(line) for line in (out / "points.jsonl").read_text().splitlines()]
    assert len(rows) == 2 and {r["summary"]["stop_time"] for r in rows} == {0.2}
    assert {r["summary"]["steps"] for r in rows} == {20}


@pytest.mark.parametrize("raw, message", [
    ({"combine": "diagonal"}, "sweep 'test': combine: 'diagonal' is not one of ['grid', 'paired', 'one-at-a-time']"),
    ({"seed": -1}, "sweep 'test': seed: -1 is less than the minimum of 0"),
    ({"axes": []}, "sweep 'test': the file: unknown keys ['axes']; known: ['axis', 'combine', 'controller_settings'"),
    ({"scenario": 3}, "sweep 'test': scenario: 3 is not a string"),
    ({"axis": [{"name": "plant.f1", "range": {"start": 0, "stop": 1}}]},
     "sweep 'test': axis 'plant.f1': range: 'num' is a required property"),
    ({"axis": [{"name": "plant.f1", "random": {"distribution": "normal", "mean": 1, "count": 3}}]},
     "sweep 'test': axis 'plant.f1': random: 'std' is a required property"),
])
def test_the_schema_names_the_file_the_key_and_what_is_allowed(raw, message):
    """Sweep files are checked by a JSON schema (orchestration.sweep.schema), as scenarios are."""
    with pytest.raises(ValueError) as refused:
        parse_sweep({"scenario": "paper-ct", **raw}, "test")
    assert str(refused.value).startswith(message) and "\n" not in str(refused.value)


def test_a_docs_block_names_the_csv_for_a_long_axis_of_single_points():
    """The shipped `controllers` sweep's 80 drawn points: the docs page names points.csv instead of an
    80-row table (issue 50: the page a reader looks things up in); the terminal summary still lists them,
    and short axes (the `robustness` sweep's, one point a value) stay tables."""
    from orchestration.sweep.results import DOC_ROWS, stored_rows

    docs = REPO / "docs"
    sweep, rows = stored_rows("controllers", docs)
    block = doc_block(sweep, rows, len(sweep.points()), [])
    assert "One row per point (80 rows)" in block and "](sweeps/controllers/points.csv)" in block
    assert (docs / "sweeps" / "controllers" / "points.csv").is_file()
    assert block.count("\n| ") < 2 * DOC_ROWS  # the controller axis's table only
    assert summary_markdown(sweep, rows, len(sweep.points())).count("\n| ") > 80
    sweep, rows = stored_rows("robustness", docs)
    assert "One row per point" not in doc_block(sweep, rows, len(sweep.points()), [])
