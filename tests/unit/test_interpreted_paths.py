"""The numpy paths the interpreted cores take (``sotc_stack.cl_matrix_numpy``) give the bits of the
loops the compiled cores run, on hypothesis-drawn rows (including zeros, signed zeros, tiny and huge
entries)."""
from array import array

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fmu_controller import sotc_stack
from fmu_controller.fixed_linalg import buffer

N = 10
entries = st.one_of(st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False),
                    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e150, -1e150]))


def rows(n: int):
    return st.lists(entries, min_size=n * N, max_size=n * N)


def bits(a: array) -> bytes:
    return a.tobytes()


@settings(max_examples=60, deadline=None)
@given(data=st.data(), n=st.integers(0, 25))
def test_cl_matrix_numpy_gives_the_bits_of_cl_matrix(data, n, interpreted):
    """``cl_matrix``'s loops (what the compiled core runs) and its numpy path."""
    E = array("d", data.draw(rows(n)))
    rew = array("d", data.draw(st.lists(entries, min_size=n, max_size=n)))
    out = []
    for numpy_path in (False, True):
        interpreted.setattr(sotc_stack, "INTERPRETED", numpy_path)
        M, b, sc = array("d", [7.0] * (N * N)), array("d", [7.0] * N), buffer(max(n, 1))
        sotc_stack.cl_matrix(n, E, rew, M, b, sc)
        out.append((bits(M), bits(b), bits(sc)))
    assert out[0] == out[1]


@pytest.fixture(scope="module")
def interpreted():
    if not sotc_stack.INTERPRETED:
        pytest.skip("the compiled sotc_stack is imported here: its cl_matrix has no numpy path to compare")
    with pytest.MonkeyPatch.context() as patch:
        yield patch
