"""Every way the project enforces a torque limit on a 2-vector, in one place, for every controller.

The paper bounds the torque norm, ||tau|| <= rho (section 2.1; rho = 4 N.m in section 4), and the
SOTC's feedforward by (5), ||tau^a|| <= rho - sigma tanh(1); it never says how a vector outside the
disc is brought back. Each controller core (SOTC: the feedforward tau^a of (4) under (5); CT, LQR and
the OTC: the total torque) selects one of these through its integer parameter ``limit_handling``
(FMU Integer parameter of the same name); the codes are the indices of ``LIMIT_HANDLINGS``:

* 0 ``radial``: radial scaling onto the disc (the Euclidean projection), which keeps the direction
  (the plainest reading of ||tau|| <= rho);
* 1 ``joint``: each entry clipped to [-bound, bound], then radial scaling onto the disc (a per-joint
  reading of the bound that still honours the norm limit);
* 2 ``accel``: the point of the disc whose acceleration D^-1 tau is closest to the requested one, in
  the D^-2 metric (``accel_projection``): it keeps the designed error dynamics as close as the budget
  allows, instead of the torque direction. An addition to the paper;
* 3 ``none``: no limit (the OTC as the paper describes it: unsaturated).

Each core keeps its historical behaviour as default (SOTC: accel; CT, LQR: radial; OTC: none), so
published numbers stay reproducible; docs/paper-notes.md (2.6) and docs/baselines.md measure all.

``clip_box`` and ``saturate_norm`` are also used on their own (the SOTC's chi_vd^a and its actuator
limit). Every loop here has an iteration bound that does not depend on the input, and every radial
result satisfies ``hypot(v1, v2) <= bound`` exactly in floating point (also for subnormal or
tiny bounds).
"""
from __future__ import annotations

import math

from fmi_slave.parameters import ParameterSpec, integer_code
from fmu_numerics.elementary import atan2, cos, hypot, sin

LIMIT_HANDLINGS = ("radial", "joint", "accel", "none")
RADIAL, JOINT, ACCEL, NONE = range(4)
LIMIT_HANDLING_TEXT = "How the torque limit is enforced: " + ", ".join(
    f"{i} = {name}" for i, name in enumerate(
        ("radial scaling of the vector (Euclidean projection)", "per-joint clip, then radial norm cap",
         "projection in the D^-2 (acceleration) metric", "no limit")))



def limit_handling_spec(default: int, what: str) -> ParameterSpec:
    """The ``limit_handling`` parameter every controller core declares; ``what`` says which torque."""
    return integer_code("limit_handling", default, len(LIMIT_HANDLINGS),
                        f"{LIMIT_HANDLING_TEXT}; applies to {what} (default {default} = {LIMIT_HANDLINGS[default]})")


# shrink_into_disc: candidate factors k_i = 1 - 2^(i - 53), i = 0 .. 53 (k_53 = 0 always fits)
SHRINK_STEPS = 54
# in_disc: below this fraction of the bound no rounded norm can exceed it (they err by a few ulps), for a
# bound of at least NORMAL_BOUND: below it, the fraction can round to the bound itself and a subnormal norm
# errs by more than 2^-40 of it, so tinier bounds always take the exact test
CLEARLY_INSIDE = 1.0 - 2.0**-40
NORMAL_BOUND = 2.0**-960
# accel_projection: bisection steps on the multiplier (halves the bracket each time; 200 >> 2 * 53)
PROJECTION_BISECTIONS = 200


def in_disc(v1: float, v2: float, bound: float, h: float | None = None) -> bool:
    """v1^2 + v2^2 <= bound^2 evaluated exactly (integer arithmetic on the floats' exact values), and the
    two rounded forms ``hypot(v1, v2)`` (``elementary``'s) and ``sqrt(v1*v1 + v2*v2)`` (also
    ``np.linalg.norm``'s) <= bound: then every norm a host computes, any ``hypot`` within 1 ulp such as
    C's, numpy's and Python's included, is <= bound as well. A test of a rounded ``hypot`` alone let
    numpy's ``hypot`` report 4.000000000000001 for a torque limited to 4.
    ``h``: ``hypot(v1, v2)`` when the caller has it already."""
    return _in_disc(v1, v2, bound, hypot(v1, v2) if h is None else h)


def _in_disc(v1: float, v2: float, bound: float, h: float) -> bool:
    """``in_disc`` with h = hypot(v1, v2) given (C types when compiled: the common case builds no object)."""
    if h <= bound * CLEARLY_INSIDE and bound >= NORMAL_BOUND:  # each rounded norm is a few ulps from the exact one
        return True
    if not (h <= bound and math.sqrt(v1 * v1 + v2 * v2) <= bound):
        return False
    return _exactly_in_disc(v1, v2, bound)


def _exactly_in_disc(v1: float, v2: float, bound: float) -> bool:
    """v1^2 + v2^2 <= bound^2 in integer arithmetic on the floats' exact values."""
    (n1, d1), (n2, d2), (nb, db) = v1.as_integer_ratio(), v2.as_integer_ratio(), bound.as_integer_ratio()
    d = max(d1, d2, db)  # powers of two: each divides the largest
    a, b, c = n1 * (d // d1), n2 * (d // d2), nb * (d // db)
    return a * a + b * b <= c * c


def shrink_into_disc(v1: float, v2: float, bound: float) -> tuple[float, float]:
    """(k v1, k v2) with k = 1 - 2^(i - 53) for the smallest i in 0 .. 53 such that
    ``in_disc(k v1, k v2, bound)`` (k = 1 if it already holds): removes the rounding that can leave a
    vector scaled onto the circle a hair outside it. For a normal vector a few ulps out, the first or
    second candidate fits (the k of one ulp, as a one-ulp walk would give); where one-ulp steps cannot
    move the product (subnormal entries), the doubling step still ends within ``SHRINK_STEPS`` tries,
    at k = 0 at the latest (bound >= 0)."""
    if _in_disc(v1, v2, bound, hypot(v1, v2)):
        return v1, v2
    k = 0.0
    for i in range(SHRINK_STEPS):
        k = 1.0 - math.ldexp(1.0, i - 53)
        if _in_disc(v1 * k, v2 * k, bound, hypot(v1 * k, v2 * k)):
            break
    return v1 * k, v2 * k


def saturate_norm(v1: float, v2: float, bound: float) -> tuple[float, float, float, bool]:
    """Scale (v1, v2) down to Euclidean norm ``bound`` if it is larger (direction kept).

    Returns (v1', v2', norm of the input, saturated); the result satisfies ``in_disc(v1', v2', bound)``."""
    norm = hypot(v1, v2)
    if _in_disc(v1, v2, bound, norm):
        return v1, v2, norm, False
    k = bound / norm if norm > bound else 1.0  # (at norm == bound a rounded norm can still exceed it)
    s1, s2 = shrink_into_disc(v1 * k, v2 * k, bound)
    return s1, s2, norm, True


def clip_box(v1: float, v2: float, bound: float) -> tuple[float, float, bool]:
    """Clip each entry to [-bound, bound]. Returns (v1', v2', changed)."""
    c1 = min(max(v1, -bound), bound)
    c2 = min(max(v2, -bound), bound)
    return c1, c2, (c1 != v1 or c2 != v2)


def limit_without_metric(v1: float, v2: float, bound: float, code: int) -> tuple[float, float, bool]:
    """A vector that is no torque (the SOTC's chi_vd^a under the bound (5)) limited as ``code`` says:
    each entry (joint), radially (radial, and accel, which has no metric to project in), or not at all."""
    if code == JOINT:
        return clip_box(v1, v2, bound)
    if code == NONE:
        return v1, v2, False
    c1, c2, _, changed = saturate_norm(v1, v2, bound)
    return c1, c2, changed


def accel_projection(
    t1: float, t2: float, bound: float, d11: float, d12: float, d22: float
) -> tuple[float, float, bool]:
    """The torque of the disc ||tau|| <= bound whose acceleration D^-1 tau is closest to D^-1 t:

        argmin (tau - t)^T D^-2 (tau - t)  s.t.  ||tau|| <= bound,   tau = (D^-2 + l I)^-1 D^-2 t, l >= 0.

    When the torque cannot be delivered, deliver the one that keeps the designed error dynamics closest
    to their design. In D's eigenbasis the KKT system is diagonal; l is found by bisection
    (||tau(l)|| decreases with l), at most ``PROJECTION_BISECTIONS`` steps."""
    n = hypot(t1, t2)
    if _in_disc(t1, t2, bound, n):
        return t1, t2, False
    half_tr, half_diff = 0.5 * (d11 + d22), 0.5 * (d11 - d22)
    rad = hypot(half_diff, d12)
    da, db = half_tr + rad, half_tr - rad  # eigenvalues of D (> 0)
    ang = 0.5 * atan2(2.0 * d12, d11 - d22)
    c, s = cos(ang), sin(ang)
    qa, qb = c * t1 + s * t2, -s * t1 + c * t2
    aa, ab = 1.0 / (da * da), 1.0 / (db * db)  # eigenvalues of D^-2
    hi = max(aa, ab) * n / bound if bound > 0.0 else math.inf  # ||tau(hi)|| <= bound
    if not math.isfinite(hi):  # a bound too small to represent the multiplier: the disc is a point
        s1, s2 = shrink_into_disc(t1 * 0.0, t2 * 0.0, bound)
        return s1, s2, True
    lo = 0.0
    for _ in range(PROJECTION_BISECTIONS):
        mid = 0.5 * (lo + hi)
        fa, fb = aa / (aa + mid) * qa, ab / (ab + mid) * qb
        if fa * fa + fb * fb > bound * bound:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    fa, fb = aa / (aa + hi) * qa, ab / (ab + hi) * qb
    s1, s2 = shrink_into_disc(c * fa - s * fb, s * fa + c * fb, bound)
    return s1, s2, True


def limit_torque(code: int, t1: float, t2: float, bound: float,
                 d11: float, d12: float, d22: float) -> tuple[float, float, bool]:
    """Enforce ||tau|| <= bound on (t1, t2) the way ``code`` (an index of ``LIMIT_HANDLINGS``) says;
    D = [[d11, d12], [d12, d22]] is the inertia the ``accel`` metric uses. Returns (tau1, tau2, changed)."""
    if code == RADIAL:
        c1, c2, _, changed = saturate_norm(t1, t2, bound)
        return c1, c2, changed
    if code == JOINT:
        b1, b2, boxed = clip_box(t1, t2, bound)
        c1, c2, _, capped = saturate_norm(b1, b2, bound)
        return c1, c2, boxed or capped
    if code == ACCEL:
        return accel_projection(t1, t2, bound, d11, d12, d22)
    return t1, t2, False
