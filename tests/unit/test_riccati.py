"""The fixed-order Riccati solver the OTC and LQR FMUs use (no scipy or LAPACK inside the FMUs) against
scipy's."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import solve_continuous_are

from fmu_controller import riccati
from fmu_controller.otc import OtcCore
from fmu_controller.riccati import RiccatiError, solve_care
from fmu_plant.dynamics import inertia_matrix

weights = st.floats(1e-3, 1e3)


@settings(max_examples=60, deadline=None)
@given(lam1=st.floats(0.1, 500), lam2=st.floats(0.1, 500), phi2=st.floats(-3.1, 3.1),
       q=weights, r1=weights, r2=weights)
def test_matches_scipy_on_the_otc_problems(lam1, lam2, phi2, q, r1, r2):
    """The OTC's frozen problem (OTC-5)/(OTC-6) over its parameter ranges: same P as scipy."""
    a = np.zeros((4, 4))
    a[:2, :2] = -np.diag([lam1, lam2])
    a[:2, 2:] = np.eye(2)
    b = np.zeros((4, 2))
    d = inertia_matrix(phi2, OtcCore().model)
    b[2:, :] = np.linalg.inv(d)
    qm, rm = q * np.eye(4), np.diag([r1, r2])
    ref = solve_continuous_are(a, b, qm, rm)
    p = solve_care(a, b, qm, rm, np.hstack([np.zeros((2, 2)), d]))
    np.testing.assert_allclose(p, ref, rtol=1e-7, atol=1e-9 * np.max(np.abs(ref)))
    residual = a.T @ p + p @ a - p @ b @ np.linalg.solve(rm, b.T @ p) + qm
    assert np.max(np.abs(residual)) <= 1e-8 * max(1.0, np.max(np.abs(p)) * np.max(np.abs(a)))


def test_otc_initial_weights_equal_scipy_solution():
    core = OtcCore()
    np.testing.assert_allclose(core.frozen_riccati(-0.5), solve_continuous_are(
        *_otc_system(core, -0.5)), rtol=1e-10, atol=1e-12)


def _otc_system(core, phi2):
    a = np.zeros((4, 4))
    a[:2, :2] = -np.diag(core.lam)
    a[:2, 2:] = np.eye(2)
    b = np.zeros((4, 2))
    b[2:, :] = np.linalg.inv(inertia_matrix(phi2, core.model))
    return a, b, core.params["q"] * np.eye(4), np.diag(core.r_diag)


def test_no_stabilising_solution_is_refused():
    """An uncontrollable unstable mode (A = 1, B = 0) has no stabilising solution."""
    with pytest.raises(RiccatiError):
        solve_care(np.array([[1.0]]), np.array([[0.0]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[0.0]]))


def test_the_solution_is_the_same_from_another_stabilising_gain():
    """Newton-Kleinman converges to the one stabilising solution whatever stabilising gain it starts
    from (to rounding), and its result does not depend on the CPU (fixed-order arithmetic)."""
    core = OtcCore()
    a, b, qm, rm = _otc_system(core, -0.5)
    d = inertia_matrix(-0.5, core.model)
    p1 = solve_care(a, b, qm, rm, np.hstack([np.zeros((2, 2)), d]))
    p2 = solve_care(a, b, qm, rm, np.hstack([np.zeros((2, 2)), 3.0 * d]))
    np.testing.assert_allclose(p1, p2, rtol=1e-12, atol=1e-12 * np.max(np.abs(p1)))


def test_an_iteration_that_does_not_converge_is_refused(monkeypatch):
    """Newton-Kleinman stopped before P repeats (here after 2 of the steps the OTC problem needs) raises
    RiccatiError naming the step count, instead of returning an unconverged P."""
    core = OtcCore()
    a, b, qm, rm = _otc_system(core, -0.5)
    d = np.linalg.inv(b[2:, :])
    gain = np.hstack([np.zeros((2, 2)), d])
    solve_care(a, b, qm, rm, gain)  # converges with the real bound
    monkeypatch.setattr(riccati, "MAX_STEPS", 2)
    with pytest.raises(RiccatiError, match="did not converge in 2 steps"):
        solve_care(a, b, qm, rm, gain)
