"""SotcController: FMI 2.0 co-simulation FMU of the saturated optimal tracking controller (SOTC)
of Dien et al. (2023), sections 2.2-3.

A thin adapter: ``fmu_controller.sotc.SotcCore`` does the maths (feedforward (4)/(5), the
saturated law (28), critic learning (30)/(31) with concurrent learning), ``ControllerSlave`` the
ports shared by every controller FMU. The critic learns in ``doStep`` over [t, t + T).
"""
from fmu_controller.slave import (
    ControllerSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_controller.sotc import SotcCore


class SotcController(Fmi2Slave):
    description = "Saturated optimal tracking controller with a single critic and concurrent learning (SOTC)"
    CORE = SotcCore
    # diagnostics of the learning state (weights, CL stack) and of time (probing): no input feedthrough
    STATE_OUTPUTS = tuple(f"W{k}" for k in range(1, 11)) + ("cl_stack_size", "cl_stack_min_eig", "pe_active", "pe")
