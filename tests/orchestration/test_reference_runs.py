"""The numbers do not change unnoticed: every shipped scenario's summary, and every output of the
``paper`` run at 401 stored samples, equal the stored reference run (``python
tests/support/reference_runs.py``) bit for bit. The cores' arithmetic does not depend on the CPU (fixed-order
loops, ``test_cpu_independence``), so no allowance is made for other machines. Both ways the cores run: as a
default build makes them (compiled where Cython and a C compiler are found, as here in CI) and built
with ``SOTC_COSIM_COMPILE=0``."""
from __future__ import annotations

import json

import numpy as np
import pytest
from support.reference_runs import DATA, comparable_summary, reference_indices

from orchestration.fmu_build.build import compiles
from orchestration.run.master import run
from orchestration.run.scenario import available_scenarios, load_scenario
from orchestration.run.summary import summarize

REFERENCE = json.loads((DATA / "reference_summaries.json").read_text())


def assert_same(got, want, where: str) -> None:
    """``got`` equals ``want`` leaf by leaf, bit for bit (NaN equals NaN); ``where`` names the leaf."""
    if isinstance(want, dict):
        assert set(got) >= set(want), f"{where}: missing {sorted(set(want) - set(got))}"
        for key in want:
            assert_same(got[key], want[key], f"{where}.{key}")
    elif isinstance(want, list):
        assert len(got) == len(want), where
        for i, (g, w) in enumerate(zip(got, want)):
            assert_same(g, w, f"{where}[{i}]")
    elif isinstance(want, float):
        assert isinstance(got, (int, float)) and (got == want or got != got and want != want), \
            f"{where}: {got!r} != {want!r}"
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def test_every_shipped_scenario_has_a_reference():
    assert sorted(REFERENCE) == sorted(available_scenarios())


# the scenarios run with the cores in Python too: every FMU a scenario uses, each controller core. The others
# (paper-literal, -near-literal, -long-pe, -pe-only) change parameters of paper's SOTC core only; the Python build
# runs each of them in the pure loop under every handling (test_cpu_independence): 28 s of the suite for no other
# code. `paper` itself (the npz's run) is compared through the Python build's FMUs with the compiled build's run,
# every output of every sample, by tests/fmu/test_compiled_cores.py (which is this run's: 12 s more here)
PYTHON_SCENARIOS = ("paper-ct", "paper-lqr", "paper-otc", "paper-perturbed")


CASES = [(name, build) for build in ("default build", "cores in Python") for name in sorted(REFERENCE)
         if build == "default build" or name in PYTHON_SCENARIOS]


@pytest.fixture
def cores_paths(request, fmu_paths, build):
    if build == "default build":
        return fmu_paths
    if not compiles():
        pytest.skip("the default build runs its cores in Python here already")
    return request.getfixturevalue("python_fmu_paths")


def test_the_python_build_runs_every_fmu_and_controller_of_the_scenarios():
    from orchestration.run.scenario import load_scenario as load

    def fmus(names):
        return {i.fmu for n in names for i in load(n).instances.values()}

    assert set(PYTHON_SCENARIOS) <= set(REFERENCE) and fmus(PYTHON_SCENARIOS) == fmus(REFERENCE)


@pytest.mark.slow
@pytest.mark.parametrize("name, build", CASES, ids=[f"{b}-{n}" for n, b in CASES])
def test_summary_equals_the_reference_run(name, build, cores_paths):
    result = run(load_scenario(name), cores_paths)
    assert not result.failed, result.error
    assert_same(comparable_summary(summarize(result)), REFERENCE[name], name)
    if name != "paper":
        return
    stored = np.load(DATA / "reference_paper.npz")
    idx = reference_indices(result.samples)
    assert np.array_equal(result.time[idx], stored["time"])
    checked = 0
    for key in stored.files:
        if key == "time":
            continue
        inst, var = key.split(".", 1)
        got, want = result.outputs[inst][var][idx], stored[key]
        bad = ~((got == want) | (np.isnan(got) & np.isnan(want)))
        assert not bad.any(), f"{key}: first differs at sample {idx[np.argmax(bad)]}: {got[bad][0]!r} != {want[bad][0]!r}"
        checked += 1
    assert checked == len(stored.files) - 1 >= 50


@pytest.mark.slow
def test_a_streamed_run_has_the_reference_summary_without_holding_its_samples(fmu_paths):
    """What `sotc-cosim run` does: the master streams blocks to the summary, keeps no arrays."""
    from orchestration.run.summary import SummaryObserver

    obs = SummaryObserver()
    result = run(load_scenario("paper"), fmu_paths, observer=obs, keep_samples=False)
    assert result.samples == 10_001 and result.outputs == {} and len(result.time) == 0
    assert_same(comparable_summary(obs.summary), REFERENCE["paper"], "paper")
