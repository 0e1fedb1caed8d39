"""The SOTC through the FMUs and the fmpy master at T = 0.01 s: the paper's section 4 results."""
import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from support.fmu_driver import DrivenFmu

from orchestration.recording.writer import BLOCK_SIZE, RunRecorder
from orchestration.run.master import run
from orchestration.run.metrics import weight_total_variation
from orchestration.run.scenario import load_scenario
from orchestration.run.summary import summarize
from orchestration.study.comparison import within_table1

WEIGHTS = [f"W{k}" for k in range(1, 11)]


@pytest.fixture(scope="module")
def paper_recorded(fmu_paths, tmp_path_factory):
    """The 100 s paper run, streamed to a recording as `sotc-cosim run` does."""
    path = tmp_path_factory.mktemp("rec") / "paper.rrd"
    with RunRecorder(path) as recorder:
        result = run(load_scenario("paper"), fmu_paths, observer=recorder, block_size=BLOCK_SIZE)
    assert not result.failed, result.error
    return result, path


@pytest.fixture(scope="module")
def paper(paper_recorded):
    return paper_recorded[0]


@pytest.fixture(scope="module")
def pe_only(fmu_paths):
    result = run(load_scenario("paper-pe-only"), fmu_paths)
    assert not result.failed, result.error
    return result


def _weights(result):
    return np.column_stack([result.outputs["controller"][w] for w in WEIGHTS])


def test_paper_run_meets_table_1_within_1_3x_and_the_torque_bound(paper):
    s = summarize(paper)
    assert s["samples"] == 10001 and s["controller"] == "SotcController"
    assert within_table1(s["mse"])  # paper Table 1 (0.0025, 0.0084), +30 %
    assert max(s["max_abs_error_last_half"]) <= 1.5e-3
    assert s["max_norm_tau"] <= 4.0 and s["samples_over_limit"] == 0
    assert len(s["final_weights"]) == 10 and s["final_weights"] == list(_weights(paper)[-1])
    assert s["cl_stack_min_eig"] > 0.0
    assert s["cost_integral"] > 0.0


def test_cl_settles_the_weights_pe_alone_keeps_them_jumping(paper, pe_only):
    """Figures 1 and 2 as numbers: weight total variation over [40, 80] s."""
    tv_cl = weight_total_variation(paper.time, _weights(paper), 40.0, 80.0)
    tv_pe = weight_total_variation(pe_only.time, _weights(pe_only), 40.0, 80.0)
    assert tv_cl < 0.1 < 0.25 < tv_pe and tv_pe > 5 * tv_cl
    c = paper.outputs["controller"]
    assert np.all(c["pe_active"][paper.time >= 0.4 - 1e-9] == 0) and np.all(c["pe_active"][paper.time < 0.4 - 1e-9] == 1)
    assert np.all(pe_only.outputs["controller"]["cl_stack_size"] == 0)
    assert c["cl_stack_size"][-1] == 20


@pytest.mark.parametrize(
    "params, name",
    [({"sigma": 4.0}, "sigma"), ({"sigma": 5.0, "rho": 4.0}, "sigma"), ({"alpha1": 0.0}, "alpha1"),
     ({"alpha1": -1.0}, "alpha1"), ({"P": 9}, "P"), ({"alpha2": math.nan}, "alpha2"), ({"W0_3": math.inf}, "W0_3")],
)
def test_invalid_parameters_are_refused_at_initialization(fmu_paths, tmp_path, params, name):
    fmu = DrivenFmu(fmu_paths["SotcController"], tmp_path / "sotc")
    fmu.set(**params)
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        fmu.fmu.exitInitializationMode()
    assert any(f"'{name}'" in m for s, m in fmu.messages if s == 3), fmu.logged()
    fmu.free()


def test_fmu_loop_equals_the_pure_core_loop(paper):
    """The FMUs add nothing and lose nothing: the master's run equals the pure sampled loop of the
    same cores (orchestration.study.pure_loop), sample by sample, to the last bit."""
    from fmu_controller.sotc import SotcCore
    from orchestration.study.pure_loop import simulate

    pure = simulate(SotcCore(**load_scenario("paper").instances["controller"].parameters))
    p, c = paper.outputs["plant"], paper.outputs["controller"]
    assert np.array_equal(pure.t, paper.time)
    # bit for bit: the FMUs keep time as k T like the master, and run the same cores
    assert np.array_equal(pure.y[:, 0], p["phi1"]) and np.array_equal(pure.y[:, 1], p["phi2"])
    assert np.array_equal(pure.tau, np.column_stack([c["tau1"], c["tau2"]]))
    assert np.array_equal(pure.outputs[:, pure.names.index("W1")], c["W1"])


def test_nonfinite_input_refuses_only_the_outputs_that_depend_on_it(fmu_paths, tmp_path):
    fmu = DrivenFmu(fmu_paths["SotcController"], tmp_path / "sotc")
    fmu.initialize()
    inputs = dict(phi1=0.5, phi2=-0.5, dphi1=0.0, dphi2=0.0, phi1_d=0.14, phi2_d=0.9, dphi1_d=-0.28,
                  dphi2_d=0.32, ddphi1_d=-0.02, ddphi2_d=0.08)
    fmu.set(**inputs)
    for k in range(30):
        fmu.fmu.doStep(k * 0.01, 0.01)
    weights = fmu.get(*WEIGHTS)
    assert any(w != 0.0 for w in weights)
    fmu.set(phi1=math.nan)
    for name in ("tau1", "z1"):  # refused naming the output and the input, never NaN with status OK
        fmu.messages.clear()
        with pytest.raises(FMICallException):
            fmu.get(name)
        assert any(f"output '{name}'" in m and "'phi1'" in m for _, m in fmu.messages), fmu.logged()
    assert fmu.get(*WEIGHTS) == weights  # the learning state is still shown, exactly
    with pytest.raises(FMICallException):
        fmu.fmu.doStep(0.3, 0.01)
    fmu.set(phi1=0.5)
    assert fmu.get(*WEIGHTS) == weights and math.isfinite(fmu.get("tau1")[0])
    fmu.free()


def test_sotc_has_lower_mse_than_otc_on_both_joints_and_stays_in_the_bound(paper, fmu_paths):
    """The paper's section 4 claim, with our OTC reconstruction (docs/baselines.md)."""
    otc = summarize(run(load_scenario("paper-otc"), fmu_paths))
    sotc = summarize(paper)
    assert sotc["mse"][0] < otc["mse"][0] and sotc["mse"][1] < otc["mse"][1]
    assert sotc["samples_over_limit"] == 0 and otc["samples_over_limit"] > 0  # OTC is unsaturated


def test_the_100_s_recording_has_every_entity_at_every_step(paper_recorded):
    from support.rrd_contents import read_entities, statics

    result, path = paper_recorded
    entities = read_entities(path)
    for name in ("/fmu/plant", "/fmu/reference", "/fmu/controller", "/controller/weights", "/torques/tau_star",
                 "/torques/tau_a", "/torques/tau", "/tracking/error", "/joints/phi1", "/workspace/arm"):
        assert len(entities[name]["step"]) == 10001, name
        assert np.array_equal(entities[name]["sim_time"], np.arange(10001, dtype=np.int64) * 10_000_000), name
    props = statics(path)["/__properties/controller"]
    assert props["alpha1"] == [[50.0]] and props["sigma"] == [[0.6]] and props["P"] == [[20.0]]
    assert props["theta_1"] == [[1.0]]  # a default the scenario file does not set: the value the FMU ran with
