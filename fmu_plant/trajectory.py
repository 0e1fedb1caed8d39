"""The paper's desired end-effector path, eq. (47), and its joint-space image through eq. (48).

    X_d = cx + r sin(w t + phase),   Y_d = cy + r cos(w t + phase)           eq. (47)

Defaults: centre (1, 1) m, radius 0.5 m, rate w = 0.5 rad/s, phase pi/2. Joint velocities and
accelerations come from the exact chain rule (``kinematics.joint_rates``), not finite differences.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from fmi_slave.parameters import (
    ParameterError,
    ParameterSpec,
    any_real,
    check_all,
    positive,
)
from fmu_numerics.elementary import cos, hypot, sin
from fmu_plant.kinematics import inverse_kinematics, joint_rates

TRAJECTORY_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    # a reachable centre lies within l1 + l2 <= 200 m of the base
    ParameterSpec("center_x", 1.0, "m", "X of the circle centre, eq. (47)", low=-200.0, high=200.0),
    ParameterSpec("center_y", 1.0, "m", "Y of the circle centre, eq. (47)", low=-200.0, high=200.0),
    positive("radius", 0.5, "m", "Circle radius, eq. (47)", high=100.0),
    # |w| <= 1e3: past the Nyquist rate pi / T = 314 rad/s of the paper's T = 0.01 s a sampled circle is
    # aliased anyway, and r w^2 stays far from overflow for every radius
    ParameterSpec("rate", 0.5, "rad/s", "Angular rate w of the path parameter, eq. (47)", low=-1e3, high=1e3),
    any_real("phase", math.pi / 2, "rad", "Phase of the path parameter, eq. (47)"),
    positive("l1", 1.0, "m", "Link 1 length used by the inverse kinematics (48)", high=100.0),
    positive("l2", 1.0, "m", "Link 2 length used by the inverse kinematics (48)", high=100.0),
)

# Names of the eight reference signals, in the order ``CircleTrajectory.sample`` returns them.
REFERENCE_SIGNALS = ("phi1_d", "phi2_d", "dphi1_d", "dphi2_d", "ddphi1_d", "ddphi2_d", "x_d", "y_d")


@dataclass(frozen=True)
class CircleTrajectory:
    center_x: float = 1.0
    center_y: float = 1.0
    radius: float = 0.5
    rate: float = 0.5
    phase: float = math.pi / 2
    l1: float = 1.0
    l2: float = 1.0

    def __post_init__(self) -> None:
        checked = check_all(TRAJECTORY_PARAMETER_SPECS, {f.name: getattr(self, f.name) for f in fields(self)})
        for name, value in checked.items():
            object.__setattr__(self, name, value)
        # the whole circle must stay inside the reachable annulus and off the singular boundary
        d = hypot(self.center_x, self.center_y)
        reach_out, reach_in = self.l1 + self.l2, abs(self.l1 - self.l2)
        if d + self.radius >= reach_out or d - self.radius <= reach_in:
            raise ParameterError(
                "radius",
                f"the circle spans distances [{d - self.radius:g}, {d + self.radius:g}] m from the base; "
                f"it must lie strictly inside ({reach_in:g}, {reach_out:g}) m to be tracked without singularity",
            )

    def path(self, t: float) -> tuple[float, float, float, float, float, float]:
        """(X, Y, dX, dY, ddX, ddY) of eq. (47) at time t."""
        return circle_path(t, self.center_x, self.center_y, self.radius, self.rate, self.phase)

    def sample(self, t: float) -> tuple[float, ...]:
        """The eight ``REFERENCE_SIGNALS`` at time t: joint references (48) and their derivatives."""
        return circle_sample(t, self.center_x, self.center_y, self.radius, self.rate, self.phase, self.l1, self.l2)


def circle_path(t: float, center_x: float, center_y: float, radius: float, rate: float,
                phase: float) -> tuple[float, float, float, float, float, float]:
    """(X, Y, dX, dY, ddX, ddY) of eq. (47) at time t (the circle's parameters as in ``CircleTrajectory``)."""
    a = rate * t + phase
    s, c = sin(a), cos(a)
    r, w = radius, rate
    return (
        center_x + r * s,
        center_y + r * c,
        r * w * c,
        -r * w * s,
        -r * w * w * s,
        -r * w * w * c,
    )


def circle_sample(t: float, center_x: float, center_y: float, radius: float, rate: float, phase: float, l1: float,
                  l2: float) -> tuple[float, float, float, float, float, float, float, float]:
    """The eight ``REFERENCE_SIGNALS`` at time t: joint references (48) of the path (47) and their
    derivatives (``kinematics.joint_rates``)."""
    x, y, dx, dy, ddx, ddy = circle_path(t, center_x, center_y, radius, rate, phase)
    phi1, phi2 = inverse_kinematics(x, y, l1, l2)
    dq1, dq2, ddq1, ddq2 = joint_rates(phi1, phi2, dx, dy, ddx, ddy, l1, l2)
    return phi1, phi2, dq1, dq2, ddq1, ddq2, x, y
