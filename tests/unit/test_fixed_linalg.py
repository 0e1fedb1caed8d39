"""The fixed-order kernels of ``fmu_numerics.fixed_linalg`` against numpy (tolerances, not bits: the
bits are pinned by tests/data/reference_bits.json), on hypothesis-drawn vectors and symmetric matrices."""
from array import array

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fmu_numerics import fixed_linalg as fl

N = 10  # the critic's size, what the controller solves
entries = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)


def vectors(n: int):
    return st.lists(entries, min_size=n, max_size=n)


def flat(m: np.ndarray) -> array:
    return array("d", np.asarray(m, dtype=float).ravel().tolist())


def spd(values: list[float], n: int, shift: float) -> np.ndarray:
    """A symmetric positive definite n x n matrix from n * n numbers: G G^T + shift I."""
    g = np.array(values).reshape(n, n)
    return g @ g.T + shift * np.eye(n)


def symmetric(values: list[float], n: int) -> np.ndarray:
    g = np.array(values).reshape(n, n)
    return 0.5 * (g + g.T)


@settings(max_examples=50, deadline=None)
@given(a=vectors(N), b=vectors(N))
def test_dot_and_dot_sequence_equal_numpy(a, b):
    want = float(np.dot(a, b))
    tol = 1e-12 * (1.0 + float(np.dot(np.abs(a), np.abs(b))))
    assert fl.dot(array("d", a), array("d", b), N) == pytest.approx(want, abs=tol)
    assert fl.dot_sequence(a, b[:7]) == pytest.approx(float(np.dot(a[:7], b[:7])), abs=tol)


@settings(max_examples=50, deadline=None)
@given(values=vectors(N * N))
def test_trace_equals_numpy(values):
    m = np.array(values).reshape(N, N)
    assert fl.trace(flat(m), N) == pytest.approx(float(np.trace(m)), abs=1e-12 * (1.0 + np.abs(m).sum()))


@settings(max_examples=50, deadline=None)
@given(values=vectors(N * N), rhs=vectors(N), shift=st.floats(0.1, 10.0))
def test_cholesky_and_solves_equal_numpy(values, rhs, shift):
    a = spd(values, N, shift)
    L = fl.buffer(N * N)
    assert fl.cholesky(flat(a), N, L)
    low = np.tril(np.array(L).reshape(N, N))
    np.testing.assert_allclose(low, np.linalg.cholesky(a), rtol=1e-9, atol=1e-9 * np.abs(a).max())
    y, x = fl.buffer(N), fl.buffer(N)
    fl.forward_substitute(L, array("d", rhs), N, y)
    np.testing.assert_allclose(low @ np.array(y), rhs, rtol=1e-9, atol=1e-9 * (1.0 + np.abs(rhs).max()))
    fl.cholesky_solve(L, array("d", rhs), N, x)
    want = np.linalg.solve(a, rhs)
    np.testing.assert_allclose(np.array(x), want, rtol=1e-7, atol=1e-7 * (1.0 + np.abs(want).max()))


@settings(max_examples=30, deadline=None)
@given(values=vectors(N * N))
def test_cholesky_refuses_a_matrix_that_is_not_positive_definite(values):
    a = symmetric(values, N)
    lowest = np.linalg.eigvalsh(a)[0]
    a = a - (lowest + 1.0) * np.eye(N)  # lambda_min = -1
    assert not fl.cholesky(flat(a), N, fl.buffer(N * N))


@settings(max_examples=50, deadline=None)
@given(values=vectors(N * N))
def test_smallest_eigenvalue_and_sturm_count_equal_numpy(values):
    m = symmetric(values, N)
    d, e, A, v, p = fl.buffer(N), fl.buffer(N), fl.buffer(N * N), fl.buffer(N), fl.buffer(N)
    lam = fl.smallest_eigenvalue(flat(m), N, d, e, A, v, p)
    eig = np.linalg.eigvalsh(m)
    scale = 1.0 + np.abs(eig).max()
    assert lam == pytest.approx(eig[0], abs=1e-9 * scale)
    # the tridiagonal form (d, e) is similar to m: same eigenvalues
    tri = np.diag(np.array(d)) + np.diag(np.array(e)[:N - 1], 1) + np.diag(np.array(e)[:N - 1], -1)
    np.testing.assert_allclose(np.linalg.eigvalsh(tri), eig, atol=1e-9 * scale)
    lo, hi = fl.gershgorin(d, e, N)
    assert lo <= eig[0] + 1e-9 * scale and eig[-1] <= hi + 1e-9 * scale
    between = [0.5 * (lo + hi) for lo, hi in zip(eig, eig[1:]) if hi - lo > 1e-6 * scale]  # clear of every eigenvalue
    for x in (eig[0] - 0.5, *between, eig[-1] + 0.5):
        assert fl.sturm_count(d, e, N, x) == int(np.sum(eig < x))


def test_a_list_becomes_a_buffer_and_a_buffer_stays_itself():
    b = fl.buffer(3)
    assert fl.as_buffer(b) is b
    assert fl.as_buffer([1.0, 2.0]) == array("d", [1.0, 2.0])
