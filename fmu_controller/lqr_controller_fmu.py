"""LqrController: FMI 2.0 and 3.0 co-simulation FMU of the LQR baseline on the feedback-linearised error
dynamics, saturated on the torque norm. A thin adapter over ``fmu_controller.lqr.LqrCore``.
"""
from fmu_controller.lqr import LqrCore
from fmu_controller.slave import (
    ControllerSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)


class LqrController(Fmi2Slave):
    description = "LQR on the feedback-linearised error dynamics with torque-norm saturation (baseline)"
    CORE = LqrCore
