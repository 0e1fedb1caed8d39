"""A scenario whose controller is an FMU file from another tool with its port map (docs/benchmark.md): checked
against the controller contract before anything runs (each refusal one line naming the scenario file and the
key, exit 2, nothing written), run by the master under the contract's names, and its torques projected
radially onto ||tau|| <= rho by the actuator before the arm gets them, the cut samples counted. The example of
examples/pd_controller (plain C, FMI 2.0) is built once for the module."""
from __future__ import annotations

import json
import zipfile
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from support.example_controller import FMU_NAME, PORTS, built_fmu

from fmu_plant.paper_setting import TORQUE_LIMIT
from orchestration.cli import main
from orchestration.run.master import run
from orchestration.run.scenario import load_scenario
from orchestration.run.summary import summarize
from orchestration.run.ported import CUT_MARGIN

# Kp 10, Kd 3, its own bound 10 N.m: about a quarter of the first second's samples ask for more than 4 N.m
GAINS = "{ Kp = 10.0, Kd = 3.0, umax = 10.0 }"


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    return built_fmu(tmp_path_factory.mktemp("pd"))


def _scenario(folder: Path, fmu: str = f"vendor/{FMU_NAME}", ports: dict | None = None,
              parameters: str = GAINS, extra: str = "") -> Path:
    """``folder/mine.toml``: the paper with the example as its controller, as docs/benchmark.md writes it."""
    ports = PORTS if ports is None else ports
    text = (f'extends = "paper"\nname = "mine"\nstop_time = 1.0\n[instances.controller]\nfmu = "{fmu}"\n'
            "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in ports.items()) + " }\n"
            f"parameters = {parameters}\n{extra}")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "mine.toml").write_text(text)
    return folder / "mine.toml"


def _vendor(folder: Path, example: Path, name: str = FMU_NAME, edit=None) -> None:
    """The example copied into ``folder/vendor``, its modelDescription changed by ``edit`` (bytes -> bytes)."""
    (folder / "vendor").mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(example) as src, zipfile.ZipFile(folder / "vendor" / name, "w") as out:
        for item in src.infolist():
            data = src.read(item)
            out.writestr(item, edit(data) if edit and item.filename == "modelDescription.xml" else data)


def _over(u1: np.ndarray, u2: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Per sample: is u1^2 + u2^2 > (rho (1 + margin))^2, in exact arithmetic on the floats?"""
    bound = Fraction(TORQUE_LIMIT) * (1 + Fraction(margin))
    return np.array([Fraction(a) ** 2 + Fraction(b) ** 2 > bound ** 2 for a, b in zip(u1, u2)])


def test_the_arm_gets_the_torques_projected_onto_the_bound_and_the_cuts_are_counted(example, tmp_path, fmu_paths):
    _vendor(tmp_path, example)
    scenario = load_scenario(str(_scenario(tmp_path)))
    assert scenario.instances["controller"].parameters == {"Kp": 10.0, "Kd": 3.0, "umax": 10.0}  # not the SOTC's
    result = run(scenario, fmu_paths)
    assert not result.failed, result.error
    ctrl = result.outputs["controller"]
    assert list(ctrl) == ["u1", "u2", "tau1", "tau2", "torque_cut"]  # what it wrote, what the arm got, the cut
    u = np.column_stack([ctrl["u1"], ctrl["u2"]])
    norm = np.hypot(u[:, 0], u[:, 1])
    over = _over(ctrl["u1"], ctrl["u2"])
    assert 0 < over.sum() < len(u)
    expected = np.where(over[:, None], u * (TORQUE_LIMIT / np.where(over, norm, 1.0))[:, None], u)
    tau = np.column_stack([ctrl["tau1"], ctrl["tau2"]])
    np.testing.assert_allclose(tau, expected, rtol=4e-16 * 8, atol=0)
    assert np.all(np.hypot(tau[:, 0], tau[:, 1]) <= TORQUE_LIMIT)
    cut = _over(ctrl["u1"], ctrl["u2"], CUT_MARGIN)
    assert np.array_equal(ctrl["torque_cut"] != 0, cut) and cut.sum() > 0
    summary = summarize(result)
    assert summary["torque_cuts"] == cut.sum() and summary["max_norm_tau"] <= TORQUE_LIMIT

    # what the arm moved with: the example bounding itself to 4 N.m by the same radial law moves it the same; its
    # scaled torques land an ulp outside the disc now and then: the actuator moves those inside, and counts none
    own = run(load_scenario(str(_scenario(tmp_path / "own", f"../vendor/{FMU_NAME}",
                                          parameters=GAINS.replace("10.0 }", "4.0 }")))), fmu_paths)
    mine = own.outputs["controller"]
    assert not own.failed and summarize(own)["torque_cuts"] == 0
    for name in ("phi1", "phi2", "dphi1", "dphi2"):
        np.testing.assert_allclose(result.outputs["plant"][name], own.outputs["plant"][name], rtol=0, atol=1e-12)
    assert np.abs(result.outputs["plant"]["phi1"][-1] - result.outputs["plant"]["phi1"][0]) > 1e-3  # it moved


def test_run_records_and_summarises_it_from_the_command_line(example, tmp_path, fmu_dir, monkeypatch, capsys):
    _vendor(tmp_path / "s", example)
    _scenario(tmp_path / "s")
    monkeypatch.chdir(tmp_path)  # the FMU's path is taken from the scenario file's folder, not from here
    code = main(["run", "s/mine.toml", "--fmu-dir", str(fmu_dir), "--summary", "s.json", "--recording", "r.rrd"])
    out = capsys.readouterr().out
    assert code == 0, out
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["status"] == "ok" and summary["controller"] == FMU_NAME and 0 < summary["torque_cuts"] < 101
    assert f" {summary['torque_cuts']} " in out.splitlines()[2] and (tmp_path / "r.rrd").stat().st_size > 0


def _ports(**change) -> dict:
    return {**PORTS, **change}


def _no_cosimulation(md: bytes) -> bytes:
    return md.replace(b"<CoSimulation", b"<ModelExchange")


@pytest.mark.parametrize("fmu, ports, parameters, vendor, said", [
    ("vendor/Nope.fmu", None, GAINS, None, "instances.controller.fmu: {dir}/vendor/Nope.fmu: no such file"),
    (f"vendor/{FMU_NAME}", None, GAINS, b"not a zip", "instances.controller.fmu: {dir}/vendor/PdController.fmu: "),
    (f"vendor/{FMU_NAME}", None, GAINS, _no_cosimulation,
     "instances.controller.fmu: {dir}/vendor/PdController.fmu: no Co-Simulation interface"),
    (f"vendor/{FMU_NAME}", _ports(phi1="u1"), GAINS, "",
     "instances.controller.ports.phi1 = 'u1': causality 'output', the contract needs an input (and 2 more"),
    (f"vendor/{FMU_NAME}", _ports(dphi1="nope"), GAINS, "", "instances.controller.ports.dphi1 = 'nope': the FMU has "
     "no variable 'nope'"),
    (f"vendor/{FMU_NAME}", _ports(phi1="dq1", dphi1="q1"), GAINS, "",
     "instances.controller.ports.phi1 = 'dq1': unit 'rad/s', the contract's is 'rad' (and 1 more"),
    (f"vendor/{FMU_NAME}", None, "{ Kp = 10.0, gain = 1.0 }", "",
     "instances.controller.parameters.gain = 1: the FMU has no variable 'gain'"),
    (f"vendor/{FMU_NAME}", None, "{ q1 = 0.5 }", "", "instances.controller.parameters.q1 = 0.5: causality 'input'"),
    (f"vendor/{FMU_NAME}", None, "{ Kd = -1.0 }", "", "instances.controller.parameters.Kd = -1: outside [0, inf]"),
    (f"vendor/{FMU_NAME}", None, "{ Kp = nan }", "", "instances.controller.parameters.Kp = nan: not a finite number"),
    ("SotcController", None, "{ rho = 4.0 }", None, "instances.controller.ports: a port map is for a controller "
     "from a file"),
    (f"vendor/{FMU_NAME}", {"foo": "q1"}, GAINS, "", "instances.controller.ports: 'foo' is not one of"),
], ids=["missing", "not a zip", "model exchange only", "causality", "no such variable", "unit", "no such parameter",
        "not a parameter", "a parameter's range", "not finite", "ports without a file", "not a contract name"])
def test_a_controller_file_that_breaks_the_contract_is_one_line_and_exit_2(
        example, tmp_path, fmu_dir, monkeypatch, capsys, fmu, ports, parameters, vendor, said):
    folder = tmp_path / "s"
    if vendor is not None:
        if isinstance(vendor, bytes):
            (folder / "vendor").mkdir(parents=True)
            (folder / "vendor" / FMU_NAME).write_bytes(vendor)
        else:
            _vendor(folder, example, edit=vendor or None)
    _scenario(folder, fmu, ports, parameters)
    monkeypatch.chdir(tmp_path)
    code = main(["run", "s/mine.toml", "--fmu-dir", str(fmu_dir), "--summary", "s.json", "--no-recording"])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == "", captured.out
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "s/mine.toml" in lines[0] and said.format(dir=folder) in lines[0], captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]  # no summary, no recording


def test_a_parameter_of_the_file_named_rho_sets_its_own_bound_not_the_harness(tmp_path):
    """The bound is the same for everyone: a controller from a file with a parameter ``rho`` of its own (which may
    mean anything to it) leaves the actuator's and the metrics' bound at the paper's 4 N.m; ours set it."""
    path = _scenario(tmp_path, parameters="{ rho = 100.0 }")
    assert load_scenario(str(path)).torque_limit() == TORQUE_LIMIT
    assert load_scenario("paper").with_parameters({"controller.rho": 3.0}).torque_limit() == 3.0


def test_a_map_that_leaves_the_reference_out_runs_without_it(example, tmp_path, fmu_paths):
    """Contract inputs the FMU does not read are left out of the map: no reference at all is a controller too
    (``[[connect]] reference -> controller`` then links nothing, as the contract allows)."""
    _vendor(tmp_path / "s", example)
    ports = {k: v for k, v in PORTS.items() if not k.endswith("_d")}
    scenario = load_scenario(str(_scenario(tmp_path / "s", ports=ports))).with_stop_time(0.2)
    result = run(scenario, fmu_paths)
    assert not result.failed, result.error
    assert np.any(result.outputs["controller"]["u1"] != 0.0)  # it steers the arm to its references' start, 0


def test_extends_takes_a_path_from_the_file_that_writes_it(example, tmp_path, monkeypatch):
    """As the fmu paths do: ``extends = "../mine.toml"`` in s/child/c.toml is s/mine.toml, from any folder."""
    _vendor(tmp_path / "s", example)
    _scenario(tmp_path / "s")
    (tmp_path / "s" / "child").mkdir()
    (tmp_path / "s" / "child" / "c.toml").write_text('extends = "../mine.toml"\nname = "child"\nstop_time = 0.5\n')
    monkeypatch.chdir(tmp_path / "s" / "child")  # where a path taken from the working folder would miss
    child = load_scenario(str(tmp_path / "s" / "child" / "c.toml"))
    assert child.stop_time == 0.5 and child.instances["controller"].file == tmp_path / "s" / "vendor" / FMU_NAME


def test_a_port_map_beside_a_plant_is_refused(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('extends = "paper"\n[instances.plant]\nfmu = "arm.fmu"\nports = { tau1 = "u" }\n')
    with pytest.raises(Exception, match="instances.plant.ports: a port map is for a controller from a file"):
        load_scenario(str(path))


def test_an_fmi3_controller_file_runs_under_its_array_elements(tmp_path, fmu_paths):
    """Our CT controller built as FMI 3.0 (phi, dphi, tau arrays of 2) as a file, mapped by element (``tau[1]``),
    its own limit off: the arm gets its torques projected, its own ``tau`` is recorded beside them (tau1_fmu)."""
    from orchestration.fmu_build.build import ensure_built
    from orchestration.fmu_build.compiled import switched

    with switched(False):  # Python cores: one FMU in a few seconds
        ensure_built(["CtController"], tmp_path / "vendor", fmi=3)
    elements = {k: f"{k[:-1]}[{k[-1]}]" for k in ("phi1", "phi2", "dphi1", "dphi2", "tau1", "tau2")}
    reference = {k: k for k in ("phi1_d", "phi2_d", "dphi1_d", "dphi2_d", "ddphi1_d", "ddphi2_d")}
    path = _scenario(tmp_path, "vendor/CtController.fmu", {**elements, **reference}, "{ limit_handling = 3 }")
    result = run(load_scenario(str(path)).with_stop_time(0.2), fmu_paths)
    assert not result.failed, result.error
    ctrl = result.outputs["controller"]
    over = _over(ctrl["tau1_fmu"], ctrl["tau2_fmu"])
    assert over.any() and summarize(result)["torque_cuts"] == _over(ctrl["tau1_fmu"], ctrl["tau2_fmu"], CUT_MARGIN).sum()
    norm = np.hypot(ctrl["tau1_fmu"], ctrl["tau2_fmu"])
    np.testing.assert_allclose(ctrl["tau1"][over], (ctrl["tau1_fmu"] * TORQUE_LIMIT / norm)[over], rtol=4e-15)
    assert np.array_equal(ctrl["tau1"][~over], ctrl["tau1_fmu"][~over])


def test_our_own_controllers_run_without_the_actuator(fmu_paths):
    result = run(load_scenario("paper").with_stop_time(0.05), fmu_paths)
    assert "torque_cut" not in result.outputs["controller"] and summarize(result)["torque_cuts"] == 0


def test_a_sweep_point_runs_the_file_on_a_worker(example, tmp_path, fmu_dir):
    """The point's task, as a Dask worker runs it (no cluster here): the file travels as bytes, its cut counted."""
    from orchestration.sweep.runner import fmu_blobs, point_key, run_point
    from orchestration.sweep.spec import grid_from_assignments

    _vendor(tmp_path, example)
    sweep = grid_from_assignments(str(_scenario(tmp_path)), ["controller.Kp=10"])
    blobs = fmu_blobs(sweep.model_names(), fmu_dir)
    [point] = sweep.points()
    key = point_key(point.scenario, {m: d for m, (d, _) in blobs.items()})
    row = run_point({"time_limit": 60.0, "state_bound": 1e3, "record": False, "point": point, "key": key}, blobs)
    assert row["status"] == "ok", row["reason"]
    assert row["summary"]["controller"] == FMU_NAME and 0 < row["summary"]["torque_cuts"] < 101
    inst = point.scenario.instances["controller"]
    other = replace(inst, ports={k: v for k, v in inst.ports.items() if k != "phi1_d"})  # another map: another point
    assert point_key(replace(point.scenario, instances={**point.scenario.instances, "controller": other}),
                     {m: d for m, (d, _) in blobs.items()}) != key


def test_sweep_refuses_a_point_the_file_would_refuse_before_anything_runs(example, tmp_path, fmu_dir, monkeypatch,
                                                                          capsys):
    _vendor(tmp_path / "s", example)
    _scenario(tmp_path / "s")
    monkeypatch.chdir(tmp_path)
    code = main(["sweep", "s/mine.toml", "--set", "controller.Kd=1,-1", "--fmu-dir", str(fmu_dir), "--out", "out"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "s/mine.toml: instances.controller.parameters.Kd = -1: outside [0, inf]" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]


def test_compare_overlays_it_beside_ours_with_its_own_outputs_under_its_entity(example, tmp_path, fmu_dir, monkeypatch,
                                                                                capsys):
    from support.rrd_contents import read_entities, statics

    _vendor(tmp_path / "s", example)
    _scenario(tmp_path / "s")
    monkeypatch.chdir(tmp_path)
    assert main(["compare", "paper", "s/mine.toml", "--stop-time", "0.2", "--fmu-dir", str(fmu_dir),
                 "--recording", "c.rrd"]) == 0, capsys.readouterr().err
    names = statics(tmp_path / "c.rrd")["/mine/fmu/controller"]["SeriesLines:names"]
    assert names == [["u1", "u2", "tau1", "tau2", "torque_cut"]]
    ents = read_entities(tmp_path / "c.rrd")
    own = np.array([row for row in ents["/mine/fmu/controller"]["Scalars:scalars"]])
    assert np.array_equal(np.array(ents["/mine/torques/tau1"]["Scalars:scalars"])[:, 0], own[:, 2])  # what the arm got
    assert "/paper/fmu/controller" in ents


def _controller_file(folder: Path, body: str | None = None) -> None:
    """``folder/pd.toml``: the example with its map and gains, as docs/benchmark.md writes a controller file (with
    the [search] table issue 49 tunes, which a sweep checks the shape of and does not run: its Kp is fixed too)."""
    ports = "ports = { " + ", ".join(f'{k} = "{v}"' for k, v in PORTS.items()) + " }\n"
    text = f'fmu = "vendor/{FMU_NAME}"\n{ports}parameters = {GAINS}\n[search]\nKp = {{ low = 1.0, high = 100.0 }}\n'
    (folder / "pd.toml").write_text(text if body is None else body)


def _sweep_file(folder: Path, values: list[str]) -> Path:
    text = ('name = "mix"\nscenario = "paper"\nstop_time = 0.3\n[[axis]]\nname = "controller"\nvalues = ['
            + ", ".join(f'"{v}"' for v in values) + "]\n")
    (folder / "sweep.toml").write_text(text)
    return folder / "sweep.toml"


def test_a_controller_axis_mixes_ours_and_a_controller_file(example, tmp_path, fmu_dir):
    """Each point as a worker runs it (no cluster here), after the contract's check every sweep makes per point."""
    from orchestration.compliance.contract import check_scenario
    from orchestration.sweep.runner import fmu_blobs, point_key, run_point
    from orchestration.sweep.spec import load_sweep

    _vendor(tmp_path, example)
    _controller_file(tmp_path)
    sweep = load_sweep(str(_sweep_file(tmp_path, ["CtController", "pd.toml"])))
    ours, theirs = sweep.points()
    controller = theirs.scenario.instances["controller"]
    assert controller.fmu == str(tmp_path / "vendor" / FMU_NAME) and controller.ports == PORTS  # from the file's folder
    assert controller.parameters == {"Kp": 10.0, "Kd": 3.0, "umax": 10.0} and theirs.settings == {"controller": "pd.toml"}
    blobs = fmu_blobs(sweep.model_names(), fmu_dir)
    digests = {m: d for m, (d, _) in blobs.items()}
    rows = []
    for point in (ours, theirs):
        check_scenario(point.scenario)
        task = {"time_limit": 60.0, "state_bound": 1e3, "record": False, "point": point,
                "key": point_key(point.scenario, digests)}
        rows.append(run_point(task, blobs))
    assert [r["status"] for r in rows] == ["ok", "ok"], [r["reason"] for r in rows]
    assert [r["summary"]["controller"] for r in rows] == ["CtController", FMU_NAME]
    assert rows[0]["summary"]["torque_cuts"] == 0 < rows[1]["summary"]["torque_cuts"]
    assert rows[0]["key"] != rows[1]["key"]
    # points.csv counts the cuts where a point runs a file (ours only: no column of zeros)
    from orchestration.sweep.results import table_csv

    table = [line.split(",") for line in table_csv(sweep, [{**r, "index": i} for i, r in enumerate(rows)]).splitlines()]
    assert table[0][-1] == "samples_cut" and [t[-1] for t in table[1:]] == ["0", str(rows[1]["summary"]["torque_cuts"])]
    assert "samples_cut" not in table_csv(load_sweep(str(_sweep_file(tmp_path, ["CtController"]))), [])


@pytest.mark.parametrize("value, body, said", [
    ("pd.toml", 'fmu = "vendor/PdController.fmu"\ngains = { Kp = 1.0 }\n', "pd.toml: the file: unknown keys ['gains']"),
    ("pd.toml", "ports = { tau1 = \"u1\" }\n", "pd.toml: the file: 'fmu' is a required property"),
    ("pd.toml", 'fmu = "vendor/PdController.fmu"\nparameters = { Kp = nan }\n', "pd.toml: parameters.Kp: nan is not finite"),
    ("pd.toml", 'fmu = "vendor/PdController.fmu"\nports = { tau3 = "u1" }\n', "pd.toml: ports: 'tau3' is not one of"),
    ("pd.toml", 'fmu = "vendor/PdController.fmu"\n[search]\nKp = { low = 1.0, high = 2.0, step = 1.0 }\n',
     "pd.toml: search.Kp: unknown keys ['step']"),
    ("nope.toml", None, "axis 'controller': nope.toml: no such file"),
    ("pd.toml", 'fmu = "vendor/Nope.fmu"\n', "axis 'controller': pd.toml: fmu: {dir}/vendor/Nope.fmu: no such file"),
    ("pd.toml", None, "axis 'controller': pd.toml: parameters.Kd = -1: outside [0, inf]"),
    (f"vendor/{FMU_NAME}", None, f"axis 'controller': vendor/{FMU_NAME}: ports.tau1 = 'tau1': the FMU has no variable"),
], ids=["unknown key", "no fmu", "nan", "not a contract name", "a search's unknown key", "no such file", "no such fmu", "its parameter's range",
        "an fmu without the contract's names"])
def test_a_bad_controller_file_in_a_sweep_is_one_line_and_exit_2(example, tmp_path, fmu_dir, monkeypatch, capsys,
                                                                 value, body, said):
    _vendor(tmp_path / "s", example)
    _controller_file(tmp_path / "s", body or ('fmu = "vendor/PdController.fmu"\nports = { tau1 = "u1", tau2 = "u2" }\n'
                                              "parameters = { Kd = -1.0 }\n"))
    _sweep_file(tmp_path / "s", ["CtController", value])
    monkeypatch.chdir(tmp_path)
    code = main(["sweep", "s/sweep.toml", "--fmu-dir", str(fmu_dir), "--out", "out"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "sweep 's/sweep.toml': axis 'controller': " in err[0] and said.format(dir=tmp_path / "s") in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]


def test_a_shipped_sweep_and_controller_settings_take_no_controller_file(tmp_path):
    from orchestration.sweep.spec import parse_sweep

    axis = [{"name": "controller", "values": ["CtController", "pd.toml"]}]
    with pytest.raises(ValueError, match="axis 'controller': pd.toml: a shipped sweep names our controllers, not files"):
        parse_sweep({"scenario": "paper", "axis": axis}, "shipped")
    with pytest.raises(ValueError, match="controller_settings.pd.toml: a controller file sets its parameters in its own"):
        parse_sweep({"scenario": "paper", "axis": axis, "controller_settings": {"pd.toml": {"controller.Kp": 1.0}}},
                    "mine", tmp_path)


def test_a_scenario_names_a_controller_file_in_place_of_fmu_and_ports(example, tmp_path, fmu_paths):
    """Its parameters over the file's (its [search] not run); a problem of the file's FMU, or of its shape, names the
    scenario's key and the file's key."""
    _vendor(tmp_path, example)
    _controller_file(tmp_path)
    (tmp_path / "scn.toml").write_text('extends = "paper"\nstop_time = 0.2\n[instances.controller]\n'
                                       'controller = "pd.toml"\nparameters = { Kd = 4.0 }\n')
    scenario = load_scenario(str(tmp_path / "scn.toml"))
    controller = scenario.instances["controller"]
    assert controller.fmu == str(tmp_path / "vendor" / FMU_NAME) and controller.ports == PORTS
    assert controller.parameters == {"Kp": 10.0, "Kd": 4.0, "umax": 10.0}
    result = run(scenario, fmu_paths)
    assert not result.failed and summarize(result)["controller"] == FMU_NAME, result.error

    from orchestration.compliance.contract import check_scenario

    _controller_file(tmp_path, 'fmu = "vendor/PdController.fmu"\nports = { tau1 = "u1", tau2 = "y2" }\n')
    with pytest.raises(ValueError, match=r"scn.toml': instances.controller.controller = 'pd.toml': ports.tau2 = 'y2': "
                                         "the FMU has no variable 'y2'"):
        check_scenario(load_scenario(str(tmp_path / "scn.toml")))
    _controller_file(tmp_path, f'fmu = "vendor/{FMU_NAME}"\n[search]\nKp = {{ low = nan, high = 1.0 }}\n')
    with pytest.raises(ValueError, match=r"scn.toml': instances.controller.controller = 'pd.toml': search.Kp.low: nan is "
                                         "not finite"):
        load_scenario(str(tmp_path / "scn.toml"))
    (tmp_path / "both.toml").write_text('extends = "paper"\n[instances.controller]\ncontroller = "pd.toml"\n'
                                        f'fmu = "vendor/{FMU_NAME}"\n')
    with pytest.raises(ValueError, match="instances.controller.controller: a controller file is for instances.controller "
                                         "of a scenario file, in place of its fmu and ports"):
        load_scenario(str(tmp_path / "both.toml"))
