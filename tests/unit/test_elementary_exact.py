"""fmu_numerics.elementary against mpmath (correctly rounded at 160 bits, huge angles reduced exactly) over
each function's whole domain: every binade of the doubles from the smallest subnormal to the largest finite,
both signs, two significands in each, plus the edges of each domain; within 1 ulp of the exact value, and
the exact value's rounding where it overflows or underflows. The long-double reference of test_elementary
holds 11 bits more than a double; this one holds 100 more and does not depend on the platform."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

mp = pytest.importorskip("mpmath")

from fmu_numerics import elementary as el  # noqa: E402

PREC = 160
MAX = 1.7976931348623157e308


def binades(lo_exp: int = -1074, hi_exp: int = 1023) -> list[float]:
    """Two significands (1 and 1.6180339887...) in every binade 2^e, e = lo_exp .. hi_exp, positive."""
    out = []
    for e in range(lo_exp, hi_exp + 1):
        for m in (1.0, 1.618033988749895):
            v = math.ldexp(m, e)
            if 0.0 < v < math.inf:
                out.append(v)
    return out


POSITIVE = binades()
BELOW_ONE = [v for v in POSITIVE if v < 1.0]
BOTH = POSITIVE + [-v for v in POSITIVE] + [0.0, -0.0, MAX, -MAX, 5e-324, -5e-324]


def ulps(ours: float, exact) -> float:
    """|ours - exact| in ulps of the exact value (the smaller ulp at a power of two); an exact value beyond the
    largest double must give its rounding (inf), an exact zero must give zero."""
    if exact == 0:
        return 0.0 if ours == 0.0 else math.inf
    rounded = float(exact)  # mpmath rounds to nearest
    if math.isinf(rounded) or math.isinf(ours):
        return 0.0 if ours == rounded else math.inf
    e = max(int(mp.floor(mp.log(abs(exact), 2))), -1022)
    return float(abs(mp.mpf(ours) - exact) / mp.ldexp(1, e - 52))


def worst(f, exact, xs) -> tuple[float, float]:
    """The largest error over xs in ulps, and where."""
    with mp.workprec(PREC):
        return max((ulps(f(x), exact(mp.mpf(x))), x) for x in xs)


UNARY = {
    "exp": (mp.exp, BOTH),
    "log": (mp.log, POSITIVE + [MAX]),
    "log1p": (mp.log1p, POSITIVE + [-v for v in BELOW_ONE] + [0.0, MAX]),
    "tanh": (mp.tanh, BOTH),
    "sinh": (mp.sinh, BOTH),
    "cosh": (mp.cosh, BOTH),
    "sin": (mp.sin, BOTH),
    "cos": (mp.cos, BOTH),
    "atanh": (mp.atanh, BELOW_ONE + [-v for v in BELOW_ONE] + [0.0, math.nextafter(1.0, 0.0)]),
    "acos": (mp.acos, BELOW_ONE + [-v for v in BELOW_ONE] + [0.0, 1.0, -1.0, math.nextafter(1.0, 0.0)]),
}


@pytest.mark.parametrize("name", list(UNARY))
def test_within_one_ulp_over_the_whole_domain(name):
    exact, xs = UNARY[name]
    error, where = worst(getattr(el, name), exact, xs)
    assert error <= 1.0, f"{name}({where!r}) is {error:.3g} ulp off"


def test_sincos_within_one_ulp_over_the_whole_domain():
    assert worst(lambda x: el.sincos(x)[0], mp.sin, BOTH)[0] <= 1.0
    assert worst(lambda x: el.sincos(x)[1], mp.cos, BOTH)[0] <= 1.0


# magnitudes for the two-argument functions: every 32nd binade, both signs, and zero
PAIRS = POSITIVE[::64] + [1.0, 3.0, MAX, 5e-324]
SIGNED = PAIRS + [-v for v in PAIRS] + [0.0]


@pytest.mark.parametrize("name, exact", [("atan2", mp.atan2), ("hypot", mp.hypot)])
def test_two_argument_functions_within_one_ulp_over_the_whole_plane(name, exact):
    f = getattr(el, name)
    with mp.workprec(PREC):
        errors = [(ulps(f(y, x), exact(mp.mpf(y), mp.mpf(x))), y, x) for y in SIGNED for x in SIGNED
                  if not (y == 0.0 and x == 0.0)]
    error, y, x = max(errors)
    assert error <= 1.0, f"{name}({y!r}, {x!r}) is {error:.3g} ulp off"


@settings(max_examples=400, deadline=None)
@given(x=st.floats(allow_nan=False, allow_infinity=False), name=st.sampled_from(list(UNARY)))
def test_any_double_within_one_ulp(x, name):
    exact, _ = UNARY[name]
    domain = {"log": x > 0.0, "log1p": x > -1.0, "atanh": abs(x) < 1.0, "acos": abs(x) <= 1.0}.get(name, True)
    if domain:
        with mp.workprec(PREC):
            assert ulps(getattr(el, name)(x), exact(mp.mpf(x))) <= 1.0
