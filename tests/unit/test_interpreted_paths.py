"""The numpy paths the interpreted core takes (``sotc_stack_interpreted.cl_matrix_numpy``,
``sotc_math_interpreted.implicit_system_array``) give the bits of the loops ``cl_matrix`` and ``implicit_system`` run (C in
the compiled core, Python otherwise), on hypothesis-drawn rows (including zeros, signed zeros, tiny and huge
entries); likewise ``math.fsum``, which the interpreted SOTC kernel calls,
and the exact-sum loop of the compiled one. Runs in either build: CI's installed package is compiled."""
import math
from array import array

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fmu_controller import sotc_kernel, sotc_math, sotc_stack
from fmu_numerics.fixed_linalg import buffer
from support.interpreted import interpreted

# the twins from their .py files in either build (CI's installed package is compiled: there the elementary
# functions' constants are C, which the twins cannot import, and the compiled build never imports them)
sotc_math_interpreted, sotc_stack_interpreted = interpreted("fmu_controller.sotc_math_interpreted",
                                                            "fmu_controller.sotc_stack_interpreted")

N = 10
entries = st.one_of(st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False),
                    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e150, -1e150]))


def rows(n: int):
    return st.lists(entries, min_size=n * N, max_size=n * N)


def bits(a: array) -> bytes:
    return a.tobytes()


@settings(max_examples=60, deadline=None)
@given(data=st.data(), n=st.integers(0, 25))
def test_cl_matrix_numpy_gives_the_bits_of_cl_matrix(data, n):
    """``cl_matrix``'s loops (C in the compiled core, Python otherwise) and the numpy path, called directly."""
    E = array("d", data.draw(rows(n)))
    rew = array("d", data.draw(st.lists(entries, min_size=n, max_size=n)))
    out = []
    for fill in (loops, sotc_stack_interpreted.cl_matrix_numpy):
        M, b, sc = array("d", [7.0] * (N * N)), array("d", [7.0] * N), buffer(max(n, 1))
        fill(n, E, rew, M, b, sc)
        out.append((bits(M), bits(b), bits(sc)))
    assert out[0] == out[1]


def loops(*args) -> None:
    """``cl_matrix`` as the compiled core runs it: its loops, never the numpy path."""
    if not sotc_stack.INTERPRETED:  # the compiled module: cl_matrix is the C loop
        sotc_stack.cl_matrix(*args)
        return
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sotc_stack, "INTERPRETED", False)
        sotc_stack.cl_matrix(*args)


summands = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                     st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1.0, 1e16, -1e16, 1.7e308, -1.7e308]))


def fsum_outcome(fn, x: array):
    """fn's sum of x as bits, or the type of what it raised."""
    try:
        return array("d", [fn(x)]).tobytes()
    except (OverflowError, ValueError) as exc:
        return type(exc)


@settings(max_examples=300, deadline=None)
@given(values=st.lists(summands, min_size=0, max_size=10))
def test_exact_sum_loop_gives_the_bits_of_math_fsum(values):
    """J_hat's sum in the compiled SOTC kernel (Shewchuk's partials over a C array) and ``math.fsum``, which
    the interpreted kernel calls: the same bits, inf and nan alike, the same error on an overflow or -inf + inf."""
    x, n = array("d", values), len(values)
    loop = fsum_outcome(lambda v: sotc_kernel.exact_sum_loop(v, n, buffer(max(n, 1))), x)
    assert loop == fsum_outcome(math.fsum, x)


@settings(max_examples=80, deadline=None)
@given(data=st.data(), with_cl=st.booleans(), dt=st.sampled_from([0.01, 1e-3, 0.5]),
       c=st.sampled_from([0.01, 2.0, 1e-6]))
def test_implicit_system_array_gives_the_bits_of_the_loops(data, with_cl, dt, c):
    """The weight step's system (I + c Gamma) W+ = rhs: ``implicit_system``'s loops and the numpy path."""
    W, wdot, xi, eta = (array("d", data.draw(rows(1))) for _ in range(4))
    M = array("d", data.draw(rows(N)))
    out = []
    for interpreted in (False, True):
        G, rhs = array("d", [7.0] * (N * N)), array("d", [7.0] * N)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(sotc_math, "INTERPRETED", interpreted)
            if interpreted:
                sotc_math_interpreted.implicit_system_array(W, wdot, xi, eta, M, with_cl, dt, c, G, rhs)
            else:
                sotc_math.implicit_system(W, wdot, xi, eta, M, with_cl, dt, c, G, rhs)
        out.append((bits(G), bits(rhs)))
    assert out[0] == out[1]


def _implicit_system_both(W, wdot, xi, eta, M, with_cl, size_G, size_rhs):
    """G and rhs (their first N*N and N entries) from ``implicit_system``'s loops and from the twin."""
    out = []
    for fill in (implicit_loops, sotc_math_interpreted.implicit_system_array):
        G, rhs = array("d", [7.0] * size_G), array("d", [7.0] * size_rhs)
        fill(W, wdot, xi, eta, M, with_cl, 0.01, 2.0, G, rhs)
        out.append((bits(G[:N * N]), bits(rhs[:N])))
    return out


def implicit_loops(*args) -> None:
    """``implicit_system`` as the compiled core runs it: its loops, never the numpy path."""
    if not sotc_math.INTERPRETED:
        sotc_math.implicit_system(*args)
        return
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sotc_math, "INTERPRETED", False)
        sotc_math.implicit_system(*args)


def test_the_weight_step_twin_reads_the_first_n_entries_as_the_loops_do():
    """Input buffers and G longer than the basis (a caller's scratch space): both read and write the first
    N (N * N) entries only; rhs has one entry per basis term (the twin takes N from it)."""
    longer = [array("d", [0.5 + k + 0.25 * j for j in range(N + 3)]) for k in range(4)]
    M = array("d", [0.001 * j for j in range(N * N + 5)])
    out = _implicit_system_both(*longer, M, True, N * N + 4, N)
    assert out[0] == out[1]


def test_the_weight_step_twin_overflows_to_inf_silently_as_the_loops_do():
    """An overflow in (I + c Gamma) gives inf entries and no warning, in the loops and in the twin alike
    (a warning turned into an error by a host's filter would otherwise stop the FMU)."""
    import warnings

    huge = [array("d", [1e200] * N) for _ in range(4)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = _implicit_system_both(*huge, array("d", [1e200] * (N * N)), True, N * N, N)
    assert out[0] == out[1] and math.isinf(array("d", out[0][1])[0])
