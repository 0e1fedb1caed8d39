"""Derives every constant of fmu_numerics/elementary.py in exact rational arithmetic (no libm, no mpmath):
pi (Machin's formula, the module's own integer version) and ln 2 (2 atanh(1/3)) to 300 bits and their
Cody-Waite splits, and each kernel polynomial by Chebyshev economization of its Taylor series on the
kernel's interval (Lanczos; Hart et al., "Computer Approximations", 1968, section 6.1): the truncated Chebyshev series is within a small
factor of the minimax polynomial of its degree, and the degree is the smallest whose dropped Chebyshev
terms sum to at most 2^-60 of the kernel's value at 0.

    python docs/elementary_coefficients.py      # prints the constants; tests/unit/test_elementary.py
                                                # checks that elementary.py holds exactly these
"""
from __future__ import annotations

import sys
from fractions import Fraction as F
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from fmu_numerics.elementary_big import _pi_scaled  # noqa: E402

BITS = 300
TOL = F(1, 2**60)


PI = F(_pi_scaled(BITS), 2**BITS)  # Machin's formula in integers (the module's, for its big reduction too)
LN2 = 2 * sum(F(1, (2 * k + 1) * 3 ** (2 * k + 1)) for k in range(100))  # 2 atanh(1/3), error < 3^-200


def split(value: F, bits: int, parts: int) -> tuple[float, ...]:
    """``value`` as ``parts`` doubles, each of the first ``parts - 1`` with at most ``bits`` significant bits
    (so k * part is exact for |k| < 2^(53 - bits)), the last rounded to nearest."""
    out = []
    for _ in range(parts - 1):
        e = value.numerator.bit_length() - value.denominator.bit_length()
        scale = F(2) ** (bits - 1 - e)
        head = F(int(value * scale), 1) / scale  # truncated to ``bits`` bits
        out.append(float(head))
        value -= head
    return (*out, float(value))


def _series_tanh(n: int) -> list[F]:
    """Taylor coefficients of tanh x / x in z = x^2 (power series division sinh / cosh)."""
    fact = [F(1)]
    for k in range(1, 2 * n + 3):
        fact.append(fact[-1] * k)
    s = [1 / fact[2 * k + 1] for k in range(n)]
    c = [1 / fact[2 * k] for k in range(n)]
    q: list[F] = []
    for k in range(n):
        q.append(s[k] - sum(q[j] * c[k - j] for j in range(k)))
    return q


def _fact(k: int) -> F:
    out = F(1)
    for j in range(2, k + 1):
        out *= j
    return out


def economize(taylor: list[F], lo: F, hi: F) -> list[float]:
    """The Taylor polynomial ``taylor`` (ascending powers of w) on [lo, hi], truncated in the Chebyshev
    basis to the smallest degree within TOL * |taylor[0]|, back in ascending powers of w."""
    n = len(taylor)
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    # coefficients in t, w = mid + half t
    t_coef = [F(0)] * n
    binom = [[F(1)]]
    for k in range(1, n):
        row = [F(1)] + [binom[-1][j - 1] + binom[-1][j] for j in range(1, k)] + [F(1)]
        binom.append(row)
    for k, a in enumerate(taylor):
        for j in range(k + 1):
            t_coef[j] += a * binom[k][j] * mid ** (k - j) * half ** j
    cheb = [[F(1)], [F(0), F(1)]]  # T_k in powers of t
    for k in range(2, n):
        prev, prev2 = cheb[-1], cheb[-2]
        cheb.append([(2 * prev[j - 1] if j else F(0)) - (prev2[j] if j < len(prev2) else 0) for j in range(k + 1)])
    c = [F(0)] * n  # Chebyshev coefficients: peel off the highest power
    rest = t_coef[:]
    for k in range(n - 1, -1, -1):
        c[k] = rest[k] / cheb[k][k]
        for j in range(k + 1):
            rest[j] -= c[k] * cheb[k][j]
    degree = n - 1
    while degree > 0 and sum(abs(x) for x in c[degree:]) <= TOL * abs(taylor[0]):
        degree -= 1
    t_poly = [sum((c[k] * cheb[k][j] for k in range(j, degree + 1) if j < len(cheb[k])), F(0))
              for j in range(degree + 1)]
    w_poly = [F(0)] * (degree + 1)  # t = (w - mid) / half
    for j, a in enumerate(t_poly):
        for i in range(j + 1):
            w_poly[i] += a * binom[j][i] * (-mid) ** (j - i) / half ** j
    return [float(x) for x in w_poly]


def kernels() -> dict[str, list[float]]:
    z_trig = F(62, 100)  # (pi/4)^2 = 0.6169 and the reduction's rounding
    return {
        "EXP": economize([1 / _fact(k + 2) for k in range(30)], F(-35, 100), F(35, 100)),  # (e^r-1-r)/r^2
        "LOG": economize([F(2, 2 * k + 3) for k in range(30)], F(0), F(295, 10000)),  # (2 atanh s - 2s)/s^3
        "TANH": economize(_series_tanh(70)[1:], F(0), F(1, 4)),  # (tanh x - x)/x^3, |x| <= 1/2
        "SINH": economize([1 / _fact(2 * k + 3) for k in range(30)], F(0), F(1)),  # (sinh x - x)/x^3, |x| <= 1
        "SIN": economize([(-1) ** (k + 1) / _fact(2 * k + 3) for k in range(30)], F(0), z_trig),
        "COS": economize([(-1) ** k / _fact(2 * k + 4) for k in range(30)], F(0), z_trig),  # (cos-1+x^2/2)/x^4
        "ATAN": economize([F((-1) ** (k + 1), 2 * k + 3) for k in range(60)], F(0), F(1915, 10000)),
    }


def _atan_half() -> F:
    """atan(1/2) to 2^-BITS (alternating series)."""
    return sum((F((-1) ** k, (2 * k + 1) * 2 ** (2 * k + 1)) for k in range(BITS)), F(0))


def constants() -> dict[str, float | tuple[float, ...]]:
    """Every named constant of elementary.py."""
    out: dict[str, float | tuple[float, ...]] = {}
    for name, value, bits, parts in (("LN2", LN2, 32, ("_HI", "_LO")), ("PIO2", PI / 2, 33, ("_1", "_2", "_3")),
                                     ("PI", PI, 53, ("_HI", "_LO")), ("HALF_PI", PI / 2, 53, ("_HI", "_LO")),
                                     ("QUARTER_PI", PI / 4, 53, ("_HI", "_LO")),
                                     ("ATAN_HALF", _atan_half(), 53, ("_HI", "_LO"))):
        out.update(zip((name + p for p in parts), split(value, bits, len(parts))))
    out.update(INV_LN2=float(1 / LN2), INV_PIO2=float(2 / PI))
    out.update({name + "_POLY": tuple(p) for name, p in kernels().items()})
    return out


if __name__ == "__main__":
    for name, value in constants().items():
        print(f"{name} = {value!r}")
