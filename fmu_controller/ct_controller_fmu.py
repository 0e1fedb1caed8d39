"""CtController: FMI 2.0 and 3.0 co-simulation FMU of the saturated computed-torque baseline.

A thin adapter: ``fmu_controller.computed_torque.CtCore`` does the maths, ``ControllerSlave``
the ports (shared by every controller FMU).
"""
from fmu_controller.computed_torque import CtCore
from fmu_controller.slave import (
    ControllerSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)


class CtController(Fmi2Slave):
    description = "Saturated computed-torque tracking controller (baseline)"
    CORE = CtCore
