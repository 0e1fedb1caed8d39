"""Bounds on a 2-vector (a torque or a virtual velocity), shared by every controller core.

* ``saturate_norm``: radial scaling onto the disc ||v|| <= bound (the Euclidean projection), which
  keeps the direction: the paper's ||tau|| <= rho (section 2.1; ``CtCore``/``LqrCore`` eq. (CT-4),
  the SOTC's bound (5) and actuator limit in their norm readings);
* ``clip_box``: each entry to [-bound, bound] (the SOTC's per-joint readings);
* ``shrink_into_disc``: the last-ulp correction both radial bounds need, so that the returned vector
  satisfies ``math.hypot(v1, v2) <= bound`` exactly in floating point.
"""
from __future__ import annotations

import math


def shrink_into_disc(v1: float, v2: float, bound: float) -> tuple[float, float]:
    """(k v1, k v2) with the largest k <= 1 (stepping down one ulp at a time) such that
    ``math.hypot(k v1, k v2) <= bound``: removes the rounding that can leave a vector scaled onto
    the circle a hair outside it. Meant for vectors already within a few ulps of the disc."""
    k = 1.0
    while math.hypot(v1 * k, v2 * k) > bound:
        k = math.nextafter(k, 0.0)
    return v1 * k, v2 * k


def saturate_norm(v1: float, v2: float, bound: float) -> tuple[float, float, float, bool]:
    """Scale (v1, v2) down to Euclidean norm ``bound`` if it is larger (direction kept).

    Returns (v1', v2', norm of the input, saturated); the result satisfies
    ``math.hypot(v1', v2') <= bound`` exactly."""
    norm = math.hypot(v1, v2)
    if norm > bound:
        k = bound / norm
        s1, s2 = shrink_into_disc(v1 * k, v2 * k, bound)
        return s1, s2, norm, True
    return v1, v2, norm, False


def clip_box(v1: float, v2: float, bound: float) -> tuple[float, float, bool]:
    """Clip each entry to [-bound, bound]. Returns (v1', v2', changed)."""
    c1 = min(max(v1, -bound), bound)
    c2 = min(max(v2, -bound), bound)
    return c1, c2, (c1 != v1 or c2 != v2)
