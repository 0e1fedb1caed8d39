"""Planar two-link kinematics: forward (49), inverse (48), and the Jacobian used to map path
velocities and accelerations to joint space analytically.

Angles in rad, lengths in m. ``phi2`` is the relative (elbow) angle, as in the paper. sincos (the sine and
cosine of one angle from one reduction), acos and atan2 are ``fmu_numerics.elementary``'s (the same bits on
every machine; docs/paper-notes.md, 2.10b).
"""
from __future__ import annotations

from fmu_numerics.elementary import acos, atan2, sin, sincos


def arm_points(phi1: float, phi2: float, l1: float, l2: float) -> tuple[float, float, float, float]:
    """The elbow (the end of link 1) and the end effector E = (X, Y) of eq. (49): (elbow x, elbow y, X, Y),
    cos and sin of phi1 once for both."""
    s1, c1 = sincos(phi1)
    sa, ca = sincos(phi1 + phi2)
    ex, ey = l1 * c1, l1 * s1
    return ex, ey, ex + l2 * ca, ey + l2 * sa


def inverse_kinematics(x: float, y: float, l1: float, l2: float) -> tuple[float, float]:
    """Joint angles reaching (x, y), eq. (48), on the branch phi2 = +arccos(...) that (48) selects.

    The paper writes arctan(Y/X); atan2 is the same on its path (X > 0) and stays right in every
    quadrant. A point outside the annulus |l1 - l2| <= r <= l1 + l2 is refused.
    """
    c2 = (x * x + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
    if not -1.0 <= c2 <= 1.0:
        raise ValueError(
            f"point ({x:g}, {y:g}) is out of reach: its distance must lie in [{abs(l1 - l2):g}, {l1 + l2:g}] m"
        )
    phi2 = acos(c2)
    sin2, cos2 = sincos(phi2)
    phi1 = atan2(y, x) - atan2(l2 * sin2, l1 + l2 * cos2)
    return phi1, phi2


def jacobian(phi1: float, phi2: float, l1: float, l2: float) -> tuple[float, float, float, float]:
    """(j11, j12, j21, j22) of J = d(X, Y)/d(phi1, phi2)."""
    s1, c1 = sincos(phi1)
    sa, ca = sincos(phi1 + phi2)
    return jacobian_of(s1, c1, sa, ca, l1, l2)


def jacobian_of(s1: float, c1: float, sa: float, ca: float, l1: float, l2: float) -> tuple[float, float, float, float]:
    """``jacobian`` from s1, c1 = sin, cos phi1 and sa, ca = sin, cos (phi1 + phi2)."""
    return -l1 * s1 - l2 * sa, -l2 * sa, l1 * c1 + l2 * ca, l2 * ca


def joint_rates(
    phi1: float, phi2: float, dx: float, dy: float, ddx: float, ddy: float, l1: float, l2: float
) -> tuple[float, float, float, float]:
    """Joint velocity and acceleration that follow a Cartesian motion, exactly:

        dphi = J^-1 [dx, dy],    ddphi = J^-1 ([ddx, ddy] - dJ/dt dphi).

    det J = l1 l2 sin(phi2); the motion must stay away from the straight-arm singularity.
    """
    s1, c1 = sincos(phi1)  # once, for J and for dJ/dt
    sa, ca = sincos(phi1 + phi2)
    j11, j12, j21, j22 = jacobian_of(s1, c1, sa, ca, l1, l2)
    det = j11 * j22 - j12 * j21
    if abs(det) < 1e-9:
        raise ValueError(f"kinematic singularity: sin(phi2) = {sin(phi2):.3g}")
    dq1 = (j22 * dx - j12 * dy) / det
    dq2 = (j11 * dy - j21 * dx) / det
    da = dq1 + dq2
    # dJ/dt dphi, differentiating each entry of J along the motion
    jd1 = (-l1 * c1 * dq1 - l2 * ca * da) * dq1 - l2 * ca * da * dq2
    jd2 = (-l1 * s1 * dq1 - l2 * sa * da) * dq1 - l2 * sa * da * dq2
    rx, ry = ddx - jd1, ddy - jd2
    ddq1 = (j22 * rx - j12 * ry) / det
    ddq2 = (j11 * ry - j21 * rx) / det
    return dq1, dq2, ddq1, ddq2
