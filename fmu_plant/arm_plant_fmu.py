"""ArmPlant: FMI 2.0 and 3.0 co-simulation FMU of the two-link arm, eq. (1)/(46) of the SOTC paper.

A thin adapter over ``fmu_plant.dynamics``: inputs are held constant over each communication step
(zero-order hold) and the state is advanced with RK4 (``substeps`` per step at least, more where the
friction or the speed make the arm stiff; ``dynamics.integrate``). A step the integrator cannot
take within its bounded number of substeps, or whose result is not physical, is refused (Discard)
with the state kept.
Outputs at a communication point are the state there, so no output depends directly on an input.
"""
from __future__ import annotations

from fmi_slave.parameters import ParameterError, ParameterSpec
from fmi_slave.slave import (
    DescribedSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_plant.dynamics import (
    ARM_PARAMETER_SPECS,
    MAX_SUBSTEPS,
    STEP_SIZE,
    ArmParameters,
    IntegrationError,
    integrate,
    substeps_needed,
)
from fmu_plant.kinematics import arm_points
from fmu_plant.paper_setting import INITIAL_ANGLES, INITIAL_VELOCITIES, SUBSTEPS

INITIAL_STATE_SPECS = (
    # |phi| <= 1e3 rad: any angle modulo 2 pi, far from where phi1 + phi2 of (49) could overflow
    ParameterSpec("phi1_0", INITIAL_ANGLES[0], "rad", "Initial angle of joint 1 (paper: 0.5)", low=-1e3, high=1e3),
    ParameterSpec("phi2_0", INITIAL_ANGLES[1], "rad", "Initial angle of joint 2, relative to link 1 (paper: -0.5)",
                  low=-1e3, high=1e3),
    # |dphi| <= 1e3 rad/s (160 rev/s): beyond that no arm of the parameter box is integrable at T = 0.01 s
    ParameterSpec("dphi1_0", INITIAL_VELOCITIES[0], "rad/s", "Initial velocity of joint 1", low=-1e3, high=1e3),
    ParameterSpec("dphi2_0", INITIAL_VELOCITIES[1], "rad/s", "Initial velocity of joint 2", low=-1e3, high=1e3),
)


class ArmPlant(Fmi2Slave):
    STEP_SIZE = STEP_SIZE  # the DefaultExperiment's step: T of the arm model (fmu_plant.dynamics)
    description = "Two-link robot arm with Coulomb-like friction (Dien et al. 2023, eq. (1)/(46))"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        specs: tuple[ParameterSpec, ...] = ARM_PARAMETER_SPECS + INITIAL_STATE_SPECS
        self._specs = specs
        for spec in specs:
            self.declare_parameter(spec)
        self.declare_integer_parameter("substeps", SUBSTEPS, 1, MAX_SUBSTEPS,
                                        "RK4 substeps per communication step, at least (more where the arm is stiff)")
        self.declare_input("tau1", "N.m", "Joint 1 actuator torque, held over the step")
        self.declare_input("tau2", "N.m", "Joint 2 actuator torque, held over the step")
        self.declare_input("d1", "N.m", "Disturbance torque on joint 1 (added to tau1)")
        self.declare_input("d2", "N.m", "Disturbance torque on joint 2 (added to tau2)")
        self.declare_output("phi1", "rad", "Joint 1 angle")
        self.declare_output("phi2", "rad", "Joint 2 angle (relative to link 1)")
        self.declare_output("dphi1", "rad/s", "Joint 1 velocity")
        self.declare_output("dphi2", "rad/s", "Joint 2 velocity")
        self.declare_output("ee_x", "m", "End-effector X, eq. (49)")
        self.declare_output("ee_y", "m", "End-effector Y, eq. (49)")
        self.declare_output("elbow_x", "m", "Elbow X")
        self.declare_output("elbow_y", "m", "Elbow Y")
        self._arm = ArmParameters()

    def initialize(self) -> None:
        values = self.parameter_values(self._specs)
        self._arm = ArmParameters.from_mapping({s.name: values[s.name] for s in ARM_PARAMETER_SPECS})
        for spec in INITIAL_STATE_SPECS:
            spec.check(values[spec.name])
        if not 1 <= int(self.substeps) <= MAX_SUBSTEPS:
            raise ParameterError("substeps", f"{self.substeps} is outside the valid range [1, {MAX_SUBSTEPS}]")
        if substeps_needed(self.phi2_0, self.dphi1_0, self.dphi2_0, STEP_SIZE, self._arm) > MAX_SUBSTEPS:
            raise ParameterError("dphi1_0", f"the initial velocities ({self.dphi1_0:g}, {self.dphi2_0:g}) rad/s "
                                 f"need more than {MAX_SUBSTEPS} RK4 substeps per {STEP_SIZE} s step for this arm")
        self._set_state(self.phi1_0, self.phi2_0, self.dphi1_0, self.dphi2_0)

    def _set_state(self, q1: float, q2: float, w1: float, w2: float) -> None:
        self.phi1, self.phi2, self.dphi1, self.dphi2 = q1, q2, w1, w2
        self.elbow_x, self.elbow_y, self.ee_x, self.ee_y = arm_points(q1, q2, self._arm.l1, self._arm.l2)

    def step(self, current_time: float, step_size: float) -> bool:
        # the base class has refused non-finite inputs already
        try:
            new = integrate((self.phi1, self.phi2, self.dphi1, self.dphi2),
                            self.tau1 + self.d1, self.tau2 + self.d2, step_size, self.substeps, self._arm)
        except IntegrationError as exc:
            return self.discard(f"step over [{current_time}, {current_time + step_size}] refused, the state is "
                                f"kept: {exc}")
        self._set_state(*new)
        return True

    def restored_values_problem(self, values) -> str | None:
        """The arm's state lives in its outputs: a restored angle or velocity stays in the range of its
        initial value (the parameters phi1_0 ... dphi2_0), and the positions on the arm's reach."""
        for spec in INITIAL_STATE_SPECS:
            name = spec.name[:-2]
            if not spec.low <= values[name] <= spec.high:
                return f"'{name}' = {values[name]!r} is outside [{spec.low:g}, {spec.high:g}] (the range of {spec.name})"
        l1, l2 = abs(values["l1"]), abs(values["l2"])
        for name, reach in (("ee_x", l1 + l2), ("ee_y", l1 + l2), ("elbow_x", l1), ("elbow_y", l1)):
            if not abs(values[name]) <= reach * (1.0 + 1e-9):
                return (f"'{name}' = {values[name]!r} is beyond the arm's reach ({reach:g} m with parameter "
                        f"'l1' = {values['l1']!r}, 'l2' = {values['l2']!r})")
        return None

    def restore_internal_state(self, state) -> None:
        if self._initialized:
            self._arm = ArmParameters.from_mapping(self.parameter_values(ARM_PARAMETER_SPECS))
