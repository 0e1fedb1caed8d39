"""``all_finite``, the one check every FMU makes of its inputs and computed outputs before it uses or
returns them: one sum in the common case, and the same answer as looking at every value."""
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from fmi_slave.slave import all_finite

EDGES = [0.0, -0.0, 5e-324, 1e308, -1e308, 1.7976931348623157e308, -1.7976931348623157e308, math.inf, -math.inf,
         math.nan]


@settings(max_examples=500, deadline=None)
@given(values=st.lists(st.one_of(st.floats(), st.sampled_from(EDGES)), max_size=50))
def test_all_finite_answers_as_a_look_at_every_value(values):
    assert all_finite(values) == all(math.isfinite(v) for v in values)
    assert all_finite(tuple(values)) == all_finite(values)


def test_finite_values_whose_sum_overflows_are_finite_and_opposite_infinities_are_not():
    assert all_finite([1e308, 1e308, -1e308])  # the sum overflows on the way: each value is still finite
    assert not all_finite([math.inf, -math.inf])  # their sum is NaN
    assert not all_finite([1.0, math.nan])
