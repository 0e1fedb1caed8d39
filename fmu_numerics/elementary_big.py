"""sin and cos's argument reduction beyond 2^20 (``elementary._reduce``), in exact integer arithmetic with pi to
1300 bits: slow, rare (no run of the cores reaches it) and the same bits on every machine, as Python integers are
exact. Plain Python in both builds: only ``elementary`` calls it.
"""
from __future__ import annotations

BIG_BITS = 1300  # bits of pi for the reduction beyond 2^20 (covers every finite double)


def _pi_scaled(bits: int) -> int:
    """pi 2^bits as an integer (Machin: pi = 16 atan(1/5) - 4 atan(1/239)), off by a few units at most."""
    one = 1 << (bits + 20)
    total = 0
    for n, weight in ((5, 16), (239, -4)):
        power, k, sign = one // n, 1, 1
        while power:
            total += weight * sign * (power // k)
            power //= n * n
            k += 2
            sign = -sign
    return total >> 20


PIO2_BIG = _pi_scaled(BIG_BITS) >> 1  # pi/2 2^BIG_BITS


def reduce_big(x: float) -> tuple:
    """(n mod 4, hi, lo) with x = n pi/2 + hi + lo, in exact integer arithmetic (any finite x)."""
    num, den = x.as_integer_ratio()
    scaled = (num << BIG_BITS) // den  # exact: den is a power of two below 2^BIG_BITS
    n = (2 * scaled + PIO2_BIG) // (2 * PIO2_BIG)
    rest = scaled - n * PIO2_BIG
    hi = rest / (1 << BIG_BITS)
    hn, hd = hi.as_integer_ratio()
    lo = (rest * hd - (hn << BIG_BITS)) / (hd << BIG_BITS)
    return float(n % 4), hi, lo  # integer arithmetic: exact
