"""The speed work must not change the numbers: every shipped scenario's summary, and every output of
the ``paper`` run at 401 stored samples, equal the stored reference run (generated before the speed
work by ``python tests/make_reference_runs.py``) to 1e-12 relative."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from orchestration.master import run
from orchestration.scenario import available_scenarios, load_scenario
from orchestration.summary import summarize
from make_reference_runs import DATA, comparable_summary, reference_indices

RTOL = 1e-12
REFERENCE = json.loads((DATA / "reference_summaries.json").read_text())


def assert_same(got, want, where: str) -> None:
    if isinstance(want, dict):
        assert set(got) >= set(want), f"{where}: missing {sorted(set(want) - set(got))}"
        for key in want:
            assert_same(got[key], want[key], f"{where}.{key}")
    elif isinstance(want, list):
        assert len(got) == len(want), where
        for i, (g, w) in enumerate(zip(got, want)):
            assert_same(g, w, f"{where}[{i}]")
    elif isinstance(want, float):
        assert isinstance(got, (int, float)) and math.isclose(got, want, rel_tol=RTOL, abs_tol=0.0), \
            f"{where}: {got!r} != {want!r}"
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def test_every_shipped_scenario_has_a_reference():
    assert sorted(REFERENCE) == sorted(available_scenarios())


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_summary_equals_the_reference_run(name, fmu_paths):
    result = run(load_scenario(name), fmu_paths)
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
        scale = float(np.max(np.abs(want))) if len(want) else 0.0
        bad = ~np.isclose(got, want, rtol=RTOL, atol=RTOL * scale)
        assert not bad.any(), f"{key}: first differs at sample {idx[np.argmax(bad)]}: {got[bad][0]!r} != {want[bad][0]!r}"
        checked += 1
    assert checked == len(stored.files) - 1 >= 50


@pytest.mark.slow
def test_a_streamed_run_has_the_reference_summary_without_holding_its_samples(fmu_paths):
    """What `sotc-cosim run` does: the master streams blocks to the summary, keeps no arrays."""
    from orchestration.summary import SummaryObserver

    obs = SummaryObserver()
    result = run(load_scenario("paper"), fmu_paths, observer=obs, keep_samples=False)
    assert result.samples == 10_001 and result.outputs == {} and len(result.time) == 0
    assert_same(comparable_summary(obs.summary), REFERENCE["paper"], "paper (streamed)")
