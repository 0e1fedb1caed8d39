"""The Python build's own paths give the bits of the loops the compiled build runs: ``elementary_interpreted``'s
exp, log1p, tanh and sinh against ``elementary``'s, element by element, ``sotc_stack_interpreted``'s replay over all
rows against ``sotc_stack.replay_current``'s loop over rows, ``fixed_linalg_interpreted``' eigenvalue against
``fixed_linalg``'s buffers, on hypothesis-drawn arguments (signed zeros, inf, nan, tiny
and huge arguments, subnormal results, every branch boundary and its neighbours, branches mixed in one array)."""
import math
from array import array

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support.interpreted import interpreted

# the interpreted build's modules, from their .py files in either build (CI's installed package is compiled:
# there elementary's constants and sotc_math's functions are C, and the compiled build never imports these paths)
el, ea, fl, sotc_math, sotc_stack_interpreted, sotc_stack = interpreted(
    "fmu_numerics.elementary", "fmu_numerics.elementary_interpreted", "fmu_numerics.fixed_linalg",
    "fmu_controller.sotc_math", "fmu_controller.sotc_stack_interpreted", "fmu_controller.sotc_stack")
CriticConstants = sotc_math.CriticConstants


def around(v: float) -> list:
    """v, its neighbours and their negatives."""
    near = [v, math.nextafter(v, math.inf), math.nextafter(v, -math.inf)]
    return near + [-u for u in near]


BOUNDARIES = sorted({u for v in (0.0, el.TINY, el.P2_M54, el.TANH_POLY_MAX, 22.0, el.SINH_POLY_MAX, el.EXP_OVER,
                                 el.EXP_UNDER, el.SINH_OVER, 1.0, 0.2928932188134524, 0.41421356237309503, 0.5,
                                 709.0, 740.0, 1022.0 * math.log(2.0), 5e-324, 2.2250738585072014e-308, 1e300,
                                 1.7976931348623157e308, math.inf)
                     for u in around(v)} | {math.nan})
ARGUMENTS = st.one_of(st.floats(), st.floats(-30.0, 30.0), st.floats(-1.0, 1.0), st.sampled_from(BOUNDARIES))


def bits(values) -> bytes:
    """Each value's 64 bits (nan's sign and payload included)."""
    return array("d", values).tobytes()


def bits_or_nan(values) -> list:
    """Each value's 64 bits, or "nan": where both operands of an operation are nan, x86 returns the first
    one's, and numpy may take a product's operands in the other order; no number differs so."""
    return ["nan" if v != v else array("d", [v]).tobytes() for v in values]


@settings(max_examples=400, deadline=None)
@given(xs=st.lists(ARGUMENTS, min_size=1, max_size=40), name=st.sampled_from(["exp", "log1p", "tanh", "sinh"]))
def test_each_element_has_the_scalar_functions_bits(xs, name):
    scalar, vector = getattr(el, name), getattr(ea, name)
    assert bits(vector(np.array(xs)).tolist()) == bits([scalar(x) for x in xs])


HYPOT_EDGES = sorted({u for v in (el.P2_M500, el.P2_500, el.P2_60, 2.0 ** -560, 1e-300, 1e300) for u in around(v)})
HYPOT_ARGUMENTS = st.one_of(ARGUMENTS, st.floats(-4.0, 4.0), st.sampled_from(HYPOT_EDGES))


@settings(max_examples=300, deadline=None)
@given(pairs=st.lists(st.tuples(HYPOT_ARGUMENTS, HYPOT_ARGUMENTS), min_size=1, max_size=40))
def test_hypot_of_each_pair_has_the_scalar_functions_bits(pairs):
    x, y = (np.array(v) for v in zip(*pairs))
    assert bits(ea.hypot(x, y).tolist()) == bits([el.hypot(a, b) for a, b in pairs])


@settings(max_examples=200, deadline=None)
@given(xs=st.lists(ARGUMENTS, min_size=1, max_size=40))
def test_the_saturated_cost_term_has_the_scalar_bits(xs):
    x = np.array(xs)
    got = sotc_stack_interpreted.x_tanh_minus_log_cosh(x, ea.tanh(x))
    assert bits(got.tolist()) == bits([sotc_math._x_tanh_minus_log_cosh(v, el.tanh(v)) for v in xs])


entries = st.one_of(st.floats(-50.0, 50.0), st.floats(-1e-3, 1e-3),
                    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e150, -1e150, 0.5, 1.0, math.inf, math.nan]))


@settings(max_examples=120, deadline=None)
@given(data=st.data(), n=st.integers(0, 25), coupled=st.booleans(), backstepping=st.booleans())
def test_the_replay_over_all_rows_has_the_loops_bits(data, n, coupled, backstepping):
    """The controller's constants with s and R drawn too (both readings of zdot and of chi_vd^a)."""
    def vector(k):
        return array("d", data.draw(st.lists(entries, min_size=k, max_size=k)))

    s = data.draw(st.sampled_from([0.5, 2.0, 30.0]))
    r = data.draw(st.lists(st.sampled_from([0.1, 1.0, 3.0]), min_size=4, max_size=4))
    K = CriticConstants(s, r, (1.0, 2.0, 0.5, 0.25), (5.0, 4.0), (3.0, 2.5), backstepping, coupled)
    W, z, dinv, fe = vector(10), vector(4 * n), vector(3 * n), vector(2 * n)
    out = []
    for replay in (loop, sotc_stack_interpreted.replay_current_array):
        E, rew = array("d", [7.0] * (10 * n)), array("d", [7.0] * n)
        replay(K, n, W, z, dinv, fe, E, rew)
        out.append((bits_or_nan(E), bits_or_nan(rew)))
    assert out[0] == out[1]


def loop(*args) -> None:
    """``replay_current``'s loop over rows (what the compiled core runs), never the array path."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sotc_stack, "INTERPRETED", False)
        sotc_stack.replay_current(*args)


matrix_entries = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e150, 1.0, 1.0]))


@settings(max_examples=150, deadline=None)
@given(values=st.lists(matrix_entries, min_size=100, max_size=100), k=st.integers(1, 10),
       zero_rows=st.integers(0, 9), gram=st.booleans(), n=st.sampled_from([10, 10, 1, 2, 3, 4]))
def test_the_eigenvalue_on_lists_has_the_loops_bits(values, k, zero_rows, gram, n):
    """``fixed_linalg.smallest_eigenvalue`` (k-th smallest) and the tridiagonal form it leaves, as the loops
    and as ``fixed_linalg_interpreted``: symmetric matrices, Gram matrices (>= 0, as the CL sum), rank-deficient
    ones; n = 10 as the critic's, and the smallest sizes, where the reduction has no or one reflection."""
    a = np.array(values).reshape(10, 10)[:n, :n]
    a[:zero_rows] = 0.0
    m = a.T @ a if gram else np.tril(a) + np.tril(a, -1).T
    k = min(k, n)
    out = []
    for interpreted in (False, True):
        d, e, A, v, p = (fl.buffer(n), fl.buffer(n), fl.buffer(n * n), fl.buffer(n), fl.buffer(n))
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(fl, "INTERPRETED", interpreted)
            lam = fl.smallest_eigenvalue(array("d", m.ravel().tolist()), n, d, e, A, v, p, k)
        out.append((bits_or_nan([lam]), bits_or_nan(d), bits_or_nan(e[:n - 1])))
    assert out[0] == out[1]
