"""The kinematics (48)/(49) and the reference path (47) against expressions derived here: sympy
differentiates the forward kinematics (49) and the circle (47), mpmath evaluates them at 30 digits; links of
unequal lengths, seeded random arm poses and circles."""
from __future__ import annotations

import math

import numpy as np
import pytest

sp = pytest.importorskip("sympy")
mp = pytest.importorskip("mpmath")

from fmi_slave.parameters import ParameterError  # noqa: E402
from fmu_plant import kinematics as kin  # noqa: E402
from fmu_plant.trajectory import CircleTrajectory, circle_path  # noqa: E402

mp.mp.dps = 30
q1, q2, L1, L2, t = sp.symbols("q1 q2 l1 l2 t", real=True)
FORWARD = sp.Matrix([L1 * sp.cos(q1) + L2 * sp.cos(q1 + q2), L1 * sp.sin(q1) + L2 * sp.sin(q1 + q2)])  # eq. (49)
ELBOW = sp.Matrix([L1 * sp.cos(q1), L1 * sp.sin(q1)])
JACOBIAN = FORWARD.jacobian([q1, q2])
POINTS = sp.lambdify((q1, q2, L1, L2), [*ELBOW, *FORWARD], "mpmath")
JAC = sp.lambdify((q1, q2, L1, L2), JACOBIAN.tolist(), "mpmath")
# d/dt of J along the motion, as a function of (q, dq): sum_k dJ/dq_k dq_k
dq1, dq2 = sp.symbols("dq1 dq2", real=True)
JDOT = sp.lambdify((q1, q2, dq1, dq2, L1, L2), (JACOBIAN.diff(q1) * dq1 + JACOBIAN.diff(q2) * dq2).tolist(), "mpmath")


def poses(seed: int, n: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        l1, l2 = rng.uniform(0.3, 2.0, 2)
        yield float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(0.2, 2.9)), float(l1), float(l2)


POSES = list(poses(49, 16))


@pytest.mark.parametrize("phi1, phi2, l1, l2", POSES)
def test_forward_kinematics_and_jacobian_are_eq_49_and_its_derivative(phi1, phi2, l1, l2):
    assert kin.arm_points(phi1, phi2, l1, l2) == pytest.approx([float(v) for v in POINTS(phi1, phi2, l1, l2)],
                                                               rel=1e-14, abs=1e-15)
    J = [[float(v) for v in row] for row in JAC(phi1, phi2, l1, l2)]
    assert kin.jacobian(phi1, phi2, l1, l2) == pytest.approx([J[0][0], J[0][1], J[1][0], J[1][1]], rel=1e-14,
                                                             abs=1e-15)


@pytest.mark.parametrize("phi1, phi2, l1, l2", POSES)
def test_inverse_kinematics_is_eq_48_on_the_elbow_up_branch(phi1, phi2, l1, l2):
    x, y = (float(v) for v in POINTS(phi1, phi2, l1, l2)[2:])
    X, Y = mp.mpf(x), mp.mpf(y)
    c2 = (X * X + Y * Y - l1 * l1 - l2 * l2) / (2 * mp.mpf(l1) * l2)
    e2 = mp.acos(c2)  # eq. (48); atan2 for arctan(Y / X), right in every quadrant
    e1 = mp.atan2(Y, X) - mp.atan2(l2 * mp.sin(e2), l1 + l2 * mp.cos(e2))
    got = kin.inverse_kinematics(x, y, l1, l2)
    assert got[1] == pytest.approx(float(e2), rel=1e-9)  # acos near 0 or pi amplifies the rounding of c2
    assert math.remainder(got[0] - float(e1), 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert got[1] == pytest.approx(phi2, rel=1e-9)  # phi2 in (0, pi): the pose itself


@pytest.mark.parametrize("l1, l2", [(1.0, 1.0), (1.5, 0.5), (0.4, 1.1)])
def test_inverse_kinematics_reaches_the_whole_annulus_and_no_further(l1, l2):
    for r, angle in ((l1 + l2, 0.3), (abs(l1 - l2) + 1e-12, -2.0), (0.5 * (l1 + l2 + abs(l1 - l2)), 2.5)):
        x, y = r * math.cos(angle), r * math.sin(angle)
        phi1, phi2 = kin.inverse_kinematics(x, y, l1, l2)
        assert kin.arm_points(phi1, phi2, l1, l2)[2:] == pytest.approx((x, y), abs=1e-6)
    for r in (l1 + l2 + 1e-9, abs(l1 - l2) * (1 - 1e-6)) if l1 != l2 else (l1 + l2 + 1e-9,):
        with pytest.raises(ValueError, match=rf"out of reach: its distance must lie in \[{abs(l1 - l2):g}, {l1 + l2:g}\] m"):
            kin.inverse_kinematics(r * 0.6, r * 0.8, l1, l2)


@pytest.mark.parametrize("phi1, phi2, l1, l2", POSES)
def test_joint_rates_invert_the_velocity_and_acceleration_maps(phi1, phi2, l1, l2):
    """dphi = J^-1 dX, ddphi = J^-1 (ddX - dJ/dt dphi), in 30 digits from sympy's J and dJ/dt."""
    dx, dy, ddx, ddy = 0.3, -0.7, 1.1, 0.4
    J = mp.matrix(JAC(phi1, phi2, l1, l2))
    dq = mp.lu_solve(J, mp.matrix([dx, dy]))
    Jd = mp.matrix(JDOT(phi1, phi2, dq[0], dq[1], l1, l2))
    ddq = mp.lu_solve(J, mp.matrix([ddx, ddy]) - Jd * dq)
    got = kin.joint_rates(phi1, phi2, dx, dy, ddx, ddy, l1, l2)
    assert got == pytest.approx([float(dq[0]), float(dq[1]), float(ddq[0]), float(ddq[1])], rel=1e-9, abs=1e-12)


def test_joint_rates_refuse_the_straight_arm():
    with pytest.raises(ValueError, match="singularity"):
        kin.joint_rates(0.4, 0.0, 0.1, 0.1, 0.0, 0.0, 1.0, 1.0)
    assert all(map(math.isfinite, kin.joint_rates(0.4, 1e-6, 0.1, 0.1, 0.0, 0.0, 1.0, 1.0)))  # det 1e-6: solved
    assert all(map(math.isfinite, kin.joint_rates(0.0, 1e-9, 0.1, 0.1, 0.0, 0.0, 1.0, 1.0)))  # det 1e-9 exactly


CIRCLES = [dict(center_x=1.0, center_y=1.0, radius=0.5, rate=0.5, phase=math.pi / 2, l1=1.0, l2=1.0),
           dict(center_x=-0.4, center_y=1.2, radius=0.3, rate=-1.7, phase=0.3, l1=1.2, l2=0.8),
           dict(center_x=0.9, center_y=-0.2, radius=0.25, rate=3.0, phase=-2.0, l1=0.7, l2=0.9)]
T = sp.symbols("t", real=True)


@pytest.mark.parametrize("circle", CIRCLES)
@pytest.mark.parametrize("time", [0.0, 1.3, 12.7, 99.9])
def test_the_reference_is_eq_47_and_its_image_through_48(circle, time):
    cx, cy, r, w, ph = (circle[k] for k in ("center_x", "center_y", "radius", "rate", "phase"))
    path = sp.Matrix([cx + r * sp.sin(w * T + ph), cy + r * sp.cos(w * T + ph)])  # eq. (47)
    exact = [float(v.subs(T, time).evalf(30)) for v in (*path, *path.diff(T), *path.diff(T, 2))]
    assert circle_path(time, cx, cy, r, w, ph) == pytest.approx(exact, rel=1e-12, abs=1e-13)
    assert CircleTrajectory(**circle).path(time) == circle_path(time, cx, cy, r, w, ph)
    sample = CircleTrajectory(**circle).sample(time)
    phi1, phi2 = kin.inverse_kinematics(*exact[:2], circle["l1"], circle["l2"])
    rates = kin.joint_rates(phi1, phi2, *exact[2:], circle["l1"], circle["l2"])
    assert sample == pytest.approx((phi1, phi2, *rates, *exact[:2]), rel=1e-11, abs=1e-12)


@pytest.mark.parametrize("change", [dict(radius=0.5 - 1e-9), dict(center_x=0.3, center_y=0.0, radius=0.29)])
def test_a_circle_strictly_inside_the_annulus_is_accepted(change):
    CircleTrajectory(**{**CIRCLES[0], **change, "center_x": change.get("center_x", 1.0)})


@pytest.mark.parametrize("change", [dict(radius=2.0 - math.hypot(1.0, 1.0)), dict(center_x=0.3, center_y=0.0, radius=0.3),
                                    dict(l1=1.5, l2=0.5, center_x=1.2, center_y=0.0, radius=0.2)])
def test_a_circle_touching_the_annulus_is_refused(change):
    c = {**CIRCLES[0], **change}
    d, l1, l2 = math.hypot(c["center_x"], c["center_y"]), c["l1"], c["l2"]
    said = (rf"parameter 'radius': the circle spans distances \[{d - c['radius']:g}, {d + c['radius']:g}\] m from the "
            rf"base; it must lie strictly inside \({abs(l1 - l2):g}, {l1 + l2:g}\) m")
    with pytest.raises(ParameterError, match=said):
        CircleTrajectory(**c)
