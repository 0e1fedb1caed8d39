"""Parameter sweeps with Dask: grid, failures recorded while the others go on, same numbers in
worker processes as in this process."""
import pytest

from orchestration.cli import main
from orchestration.scenario import ScenarioError, load_scenario
from orchestration.sweep import parse_assignments, run_sweep, variants

GRID = {"controller.kp": [25.0, 100.0, -1.0], "controller.kd": [10.0]}


@pytest.fixture(scope="module")
def base():
    return load_scenario("paper-ct").with_stop_time(1.0)


def test_grid_is_the_cartesian_product_in_order(base):
    vs = variants(base, {"controller.kp": [1.0, 2.0], "plant.f1": [8.0, 9.0, 10.0]})
    assert [o for o, _ in vs][:4] == [
        {"controller.kp": 1.0, "plant.f1": 8.0}, {"controller.kp": 1.0, "plant.f1": 9.0},
        {"controller.kp": 1.0, "plant.f1": 10.0}, {"controller.kp": 2.0, "plant.f1": 8.0}]
    assert len(vs) == 6 and vs[4][1].instances["plant"].parameters["f1"] == 9.0
    assert vs[4][1].instances["controller"].parameters["kp"] == 2.0
    assert base.instances["controller"].parameters == {}  # the base is untouched


def test_a_failed_variant_is_recorded_and_the_others_go_on_under_the_process_pool(base, fmu_paths):
    local = run_sweep(base, GRID, fmu_paths, scheduler="synchronous")
    remote = run_sweep(base, GRID, fmu_paths, scheduler="processes", workers=2)
    assert [r["status"] for r in remote] == ["ok", "ok", "failed"]
    assert "'kp'" in remote[2]["error"]
    assert remote[0]["mse"] != remote[1]["mse"]  # the override reached the FMU
    # the same numbers whether the runs happen here or in worker processes
    assert [r["mse"] for r in remote[:2]] == [r["mse"] for r in local[:2]]
    assert [r["parameters"] for r in remote] == [{"controller.kp": k, "controller.kd": 10.0} for k in (25.0, 100.0, -1.0)]


def test_sweep_command_writes_csv_and_json(fmu_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(["sweep", "paper-ct", "--set", "controller.kp=25,-1", "--stop-time", "0.5",
                 "--scheduler", "synchronous", "--fmu-dir", str(fmu_dir)])
    assert code == 1  # one variant failed
    lines = (tmp_path / "recordings" / "sweep-paper-ct.csv").read_text().splitlines()
    assert lines[0].startswith("controller.kp,status,mse_1") and len(lines) >= 3
    assert lines[1].startswith("25.0,ok,") and lines[2].startswith("-1.0,failed,")
    assert (tmp_path / "recordings" / "sweep-paper-ct.json").is_file()


@pytest.mark.parametrize("item", ["kp=1", "controller.kp", "controller.kp=a,b", "controller.kp="])
def test_bad_assignments_are_refused(item):
    with pytest.raises(ScenarioError):
        parse_assignments([item])


def test_override_of_an_unknown_instance_is_refused(base):
    with pytest.raises(ScenarioError, match="nosuch"):
        base.with_parameters({"nosuch.kp": 1.0})


def test_cluster_scheduler_without_distributed_says_what_to_install(base, fmu_paths, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_distributed(name, *args, **kwargs):
        if name == "distributed":
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_distributed)
    with pytest.raises(ScenarioError, match="distributed"):
        run_sweep(base, {"controller.kp": [25.0]}, fmu_paths, scheduler="tcp://127.0.0.1:1")
