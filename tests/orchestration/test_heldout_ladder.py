"""The ladder on the held-out points (orchestration.study.heldout_ladder): the stored runs (docs/heldout-ladder.json)
are what the code gives now, and the table's arithmetic on a hand-made store."""
from __future__ import annotations

from pathlib import Path

import pytest

from orchestration.reports import heldout_tables
from orchestration.reports.fair_tables import VERDICT_HANDLING
from orchestration.study import fair, heldout_ladder
from orchestration.study.comparison import NOMINAL
from fmu_controller.saturation import LIMIT_HANDLINGS

REPO = Path(__file__).resolve().parents[2]  # the checkout's store (the installed package has no docs/)


def _store() -> dict:
    if not (REPO / heldout_tables.STORE).is_file():
        pytest.skip(f"no {heldout_tables.STORE} beside the tests (an installed package)")
    return heldout_tables.stored(REPO)


def test_the_store_holds_every_design_and_point_of_the_study_now():
    data = _store()
    designs = fair.configurations(LIMIT_HANDLINGS.index(VERDICT_HANDLING))
    assert {label: dict(d["params"]) for label, d in data["designs"].items()} == {
        label: params for label, (_, params) in designs.items()}, f"rerun {heldout_tables.STORE}"
    assert data["copies"] == [list(p) for p in heldout_ladder.COPIES]
    assert (data["draw"], data["n_points"], data["handling"]) == (heldout_ladder.DRAW, heldout_ladder.N_POINTS,
                                                                  VERDICT_HANDLING)
    for d in data["designs"].values():
        assert all(len(d["mse"][which]) == heldout_ladder.N_POINTS for which in fair.SETS)
        assert all(len(runs) == 1 + len(heldout_ladder.COPIES) for which in fair.SETS for runs in d["mse"][which])


def test_the_runs_as_drawn_are_the_fair_comparisons_runs():
    """The unperturbed run of a point is the held-out run of docs/fair/evaluation.json, bit for bit."""
    data, fair_data = _store(), fair.stored(REPO)
    for label, d in data["designs"].items():
        for which in fair.SETS:
            want = fair.measure(fair_data, VERDICT_HANDLING, label, which, "mse", data["draw"])[:data["n_points"]]
            assert [runs[0] for runs in d["mse"][which]] == want, label


@pytest.mark.slow  # four 20 s runs in the interpreted build
@pytest.mark.parametrize("label", ["SOTC tuned, seed 0", "CT tuned, seed 0"])
def test_a_stored_run_and_its_largest_copy_are_what_the_runs_give(label):
    d = _store()["designs"][label]
    point = heldout_ladder.points()["perturbed"][0]
    params = dict(d["params"])
    got = [fair.run_point(d["fmu"], params, heldout_ladder.perturbed(point, p))["mse"]
           for p in (NOMINAL, heldout_ladder.COPIES[-1])]
    stored_runs = d["mse"]["perturbed"][0]
    assert got == [stored_runs[0], stored_runs[-1]], f"{label}: rerun {heldout_tables.STORE}"


def test_a_perturbed_point_changes_only_its_initial_state():
    point = heldout_ladder.points()["perturbed"][0]
    copy = heldout_ladder.perturbed(point, (1e-8, -1e-8, 2e-8, 0.0))
    assert copy["phi0"] == (point["phi0"][0] * (1 + 1e-8), point["phi0"][1] * (1 - 1e-8))
    assert copy["dphi0"] == (2e-8, 0.0)
    assert {k: v for k, v in copy.items() if k not in ("phi0", "dphi0")} == {k: v for k, v in point.items() if k != "phi0"}


def _design(fmu: str, a: list[float], b: list[float]) -> dict:
    return {"fmu": fmu, "params": [], "mse": {"initial states": [a], "perturbed": [b]}}


def _hand_made() -> dict:
    """Two points, six copies: the SOTC's first point jumps under the last copy, its second by 8e-4."""
    flat = lambda v: [v] * 7  # noqa: E731
    return {"handling": "accel", "draw": 7, "n_points": 1, "stop_time": 20.0, "copies": [[0.0] * 4] * 6, "designs": {
        "SOTC tuned, seed 0": _design("SotcController", [1.0] * 6 + [1.5], [2.0, 2.0016] + [2.0] * 5),
        "CT tuned, seed 0": _design("CtController", flat(1.25), [1.25] * 6 + [1.75]),
        "LQR tuned, seed 0": _design("LqrController", flat(2.0), flat(2.0)),
        "OTC tuned, seed 0": _design("OtcController", flat(3.0), flat(3.0))}}


def test_the_table_arithmetic_on_a_hand_made_store():
    data = _hand_made()
    sotc, ct = data["designs"]["SOTC tuned, seed 0"], data["designs"]["CT tuned, seed 0"]
    assert heldout_tables.copy_means(sotc) == pytest.approx([1.5, 1.5008, 1.5, 1.5, 1.5, 1.5, 1.75])
    assert heldout_tables.spreads(sotc) == pytest.approx([0.5, 0.0008])
    assert heldout_tables.moving(sotc) == 1  # 8e-4 is within JUMP (1e-3), 0.5 is not
    assert heldout_tables.best_baseline(data["designs"], [0]) == "CT tuned, seed 0"
    # per point: (1 - 1.25, 2 - 1.25) as drawn, (1.5 - 1.25, 2 - 1.75) under the last copy
    assert heldout_tables.differences(sotc, ct) == pytest.approx([0.25, 0.2508, 0.25, 0.25, 0.25, 0.25, 0.25])


def test_the_rendered_row_says_the_range_the_jumps_and_a_flipped_sign():
    data = _hand_made()
    data["designs"]["CT tuned, seed 0"] = _design("CtController", [1.25] * 6 + [2.0], [1.25] * 6 + [2.0])  # SOTC - CT: -0.25 under the last copy
    text = heldout_tables.table_of(data, [0])
    row = next(line for line in text.splitlines() if line.startswith("| SOTC tuned, seed 0 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1:8] == ["1.5", "1.5–1.75", "17 %", "25 %", "50 %", "1 of 2",
                          "0.25 (-0.25 to 0.251), **sign flips under 1 of 6**"]
    assert "Against CT tuned, seed 0" in text and text.endswith("under every copy for 0 of its 1 tuning seeds.")
