"""The fixed-order linear algebra of printed numbers (``orchestration.study.ordered``) and the value study's
LQR weights, against numpy's and scipy's LAPACK-based routines as the independent basis (to rounding)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import matrix_to_weights
from fmu_plant.dynamics import inertia_matrix
from orchestration.study import ordered
from orchestration.study.sotc_study import lqr_weights

finite = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)


@given(arrays(float, st.integers(1, 12), elements=finite))
def test_norm_is_numpys_to_rounding(x):
    assert ordered.norm(x) == pytest.approx(np.linalg.norm(x), rel=1e-14, abs=1e-300)


@given(arrays(float, (7, 4), elements=finite), arrays(float, 4, elements=st.floats(0.0, 5.0)))
def test_weighted_squares_is_the_matrix_product_to_rounding(z, w):
    assert np.allclose(ordered.weighted_squares(z, w), z ** 2 @ w, rtol=1e-14, atol=1e-12)


def test_weighted_squares_sums_left_to_right():
    # 1 + 1e-16 + 1e-16: left to right the small terms vanish one by one; summed first they would not
    z = np.sqrt(np.array([[1.0, 1e-16, 1e-16]]))
    assert ordered.weighted_squares(z, [1.0, 1.0, 1.0])[0] == 1.0


@given(arrays(float, (3, 5), elements=finite), arrays(float, (5, 2), elements=finite))
def test_product_is_the_matrix_product_to_rounding(a, b):
    assert np.allclose(ordered.product(a, b), a @ b, rtol=1e-12, atol=1e-10)


def test_product_refuses_shapes_that_do_not_chain():
    with pytest.raises(ValueError, match="do not chain"):
        ordered.product(np.ones((2, 3)), np.ones((2, 3)))


@settings(max_examples=50)
@given(arrays(float, (6, 6), elements=finite))
def test_eigvalsh_is_lapacks_to_the_rounding_level(a):
    m = a + a.T
    scale = max(1.0, float(np.abs(m).sum()))
    assert np.allclose(ordered.eigvalsh(m), np.linalg.eigvalsh(m), rtol=0, atol=1e-12 * scale)


def test_singular_values_and_rank():
    e = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])  # rank 2
    assert np.allclose(ordered.singular_values(e), np.linalg.svd(e, compute_uv=False), atol=1e-7)
    assert ordered.rank(e) == np.linalg.matrix_rank(e) == 2
    assert ordered.rank(np.eye(5)) == 5


@pytest.mark.parametrize("reading", [{}, {"chi_a_form": 1}, {"fv_error_form": 1}])
@pytest.mark.parametrize("phi2", [0.6, 1.39, 2.2])
def test_lqr_weights_solve_the_riccati_equation_as_scipy_does(reading, phi2):
    """The fixed-order Newton-Kleinman solution against scipy's Schur solver of the same (A, B, Q, R),
    set up here from the linearised (6)/(7) with numpy's inverse of D."""
    ctrl = SotcCore(**reading)
    arm = ctrl.model
    a = np.zeros((4, 4))
    if ctrl.backstepping:
        a[:2, :2], a[:2, 2:] = -np.diag(ctrl.lam1), np.eye(2)
    else:
        a[:2, 2:] = np.eye(2) + np.diag(ctrl.lam1)
    a[2:, :2], a[2:, 2:] = -np.eye(2), -np.diag(ctrl.lam2)
    if ctrl.fv_drift:
        a[2:, 2:] -= np.linalg.inv(inertia_matrix(0.0, arm)) @ np.diag([arm.f1 + arm.b1, arm.f2 + arm.b2])
    b = np.zeros((4, 4))
    b[:2, :2], b[2:, 2:] = np.eye(2), np.linalg.inv(inertia_matrix(phi2, arm))
    want = matrix_to_weights(scipy.linalg.solve_continuous_are(a, b, np.diag(ctrl.theta), np.diag(ctrl.r)))
    assert np.allclose(lqr_weights(phi2, ctrl), want, rtol=1e-11, atol=1e-13)
