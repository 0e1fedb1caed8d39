"""The CL stack's swap decisions do not rest on rounding: every offer to the full stack, re-decided with
its thresholds moved by +eps trace(M) and by -eps trace(M), picks the same row
(``orchestration.study.swap_margin``), in `paper` under every handling of the bound, and in every stored
tuned SOTC design but for one offer at most, each on its nominal 100 s `paper` loop. The earlier tolerance n eps trace(M) in the
margin's place does flip: the count can fail. (The study's stress cases still flip now and then, where a
gain creeps across its threshold by less than eps trace(M) per offer: docs/paper-notes.md 2.10a.)"""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from fmu_numerics.fixed_linalg import EPS, MAX_HALVINGS, buffer, halvings, smallest_eigenvalue
from fmu_controller.saturation import LIMIT_HANDLINGS, RADIAL
from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import N_BASIS
from fmu_controller.sotc_stack import SWAP_MARGIN
from orchestration.reports.numerics_tables import stored_flips
from orchestration.study.swap_margin import MARGINS, cases, flip_counts, stress_cases

CASES = cases()
PAPER_RADIAL = next(c for c in CASES if c[0] == "`paper`" and c[1] == RADIAL)
REPO = Path(__file__).resolve().parents[2]  # the checkout's store (the installed package has no docs/)


def _stored(case, margin: float = SWAP_MARGIN) -> dict[str, int]:
    """The counts docs/swap-flips.json holds for ``case`` (the docs' table prints them)."""
    row = next(r for r in stored_flips(REPO) if (r[0], r[1]) == case[:2])
    return row[3][MARGINS.index(margin)]


def _counts(case, margin: float = SWAP_MARGIN) -> dict[str, int]:
    return flip_counts(tuple(sorted(case[2].items())), margin)


def test_paper_radial_decides_no_offer_on_rounding():
    counts = _counts(PAPER_RADIAL)
    assert counts["offers"] > 1000 and counts["swaps"] > 0  # the stack was full and did swap
    assert counts["flips"] == 0 and counts == _stored(PAPER_RADIAL), counts


@pytest.mark.parametrize("margin", MARGINS[1:])
def test_under_a_smaller_margin_decisions_rest_on_rounding_as_stored(margin):
    """The instrument sees flips where there are some: n eps trace(M) (and a tenth of the margin) in the
    margin's place; the stored counts of the docs' table are this run's."""
    counts = _counts(PAPER_RADIAL, margin)
    assert counts["flips"] > 0 and counts == _stored(PAPER_RADIAL, margin)


@pytest.mark.slow
@pytest.mark.parametrize("case", [c for c in CASES if c is not PAPER_RADIAL], ids=lambda c: f"{c[0].replace('`', '')} {LIMIT_HANDLINGS[c[1]]}")
def test_no_decision_rests_on_rounding(case):
    """`paper`: no flip under any handling. A tuned design: at most one offer in its run, a single crossing of
    a threshold by less than eps trace(M), which no margin removes (docs/paper-notes.md 2.10a)."""
    counts = _counts(case)
    assert counts["offers"] > 1000 and counts["flips"] <= (0 if case[0] == "`paper`" else 1), counts
    assert counts == _stored(case), "rerun: python -m orchestration.reports.numerics_tables"


@pytest.mark.slow
@pytest.mark.parametrize("case, margin", [(c, MARGINS[1 + i % 2]) for i, c in enumerate(CASES) if c is not PAPER_RADIAL]
                         + [(c, m) for c in stress_cases() for m in MARGINS],
                         ids=lambda v: f"{v:.0e}" if isinstance(v, float) else f"{v[0].replace('`', '')} {LIMIT_HANDLINGS[v[1]]}")
def test_a_case_counts_what_the_docs_print(case, margin):
    """The docs' table (docs/swap-flips.json) against this code: every case at the margin above, each case here
    at one of the two smaller margins in turn, and the stress cases at all three."""
    assert _counts(case, margin) == _stored(case, margin), "rerun: python -m orchestration.reports.numerics_tables"


@pytest.mark.parametrize("below", [True, False])
def test_an_eigenvalue_counts_from_the_margin_up(below):
    """M = diag(1, ..., 1, x) with x just below or at the margin: rank 9 and lambda_min 0, or rank 10."""
    stack = SotcCore().stack
    N = N_BASIS
    x = (0.5 if below else 2.0) * SWAP_MARGIN * (N - 1)  # the margin is SWAP_MARGIN (N - 1 + x)
    stack.M = buffer(N * N)
    for a in range(N):
        stack.M[a * N + a] = 1.0 if a < N - 1 else x
    lam, rank, got_margin = stack.spectrum()
    assert got_margin == pytest.approx(SWAP_MARGIN * (N - 1 + x), rel=1e-12)
    assert (rank, lam) == ((N - 1, 0.0) if below else (N, pytest.approx(x, abs=2 * EPS * N)))


def test_the_bisection_halves_as_often_as_its_interval_needs():
    assert halvings(1.0, 2.0 ** -10) == 10
    assert halvings(1.0, 1.0) == 0
    assert halvings(1.0, 0.0) == MAX_HALVINGS
    assert halvings(3.0, EPS) == 54  # 3 / 2^54 <= 2^-52 < 3 / 2^53


def test_the_k_th_smallest_eigenvalue_is_bisected():
    """The second-difference matrix (2 on the diagonal, -1 beside it) has the eigenvalues
    2 - 2 cos(k pi / (n + 1)), k = 1 .. n: the swap rule's lambda_k below full rank."""
    N = N_BASIS
    M = buffer(N * N)
    for a in range(N):
        M[a * N + a] = 2.0
        if a:
            M[a * N + a - 1] = M[(a - 1) * N + a] = -1.0
    d, e, A, v, p = buffer(N), buffer(N), buffer(N * N), buffer(N), buffer(N)
    for k in range(1, N + 1):
        got = smallest_eigenvalue(M, N, d, e, A, v, p, k)
        assert got == pytest.approx(2.0 - 2.0 * math.cos(k * math.pi / (N + 1)), abs=4 * N * EPS * 2 * N)
