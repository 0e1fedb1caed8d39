"""SotcController: FMI 2.0 and 3.0 co-simulation FMU of the saturated optimal tracking controller (SOTC)
of Dien et al. (2023), sections 2.2-3.

A thin adapter: ``fmu_controller.sotc.SotcCore`` does the maths (feedforward (4)/(5), the
saturated law (28), critic learning (30)/(31) with concurrent learning), ``ControllerSlave`` the
ports shared by every controller FMU. The critic learns in ``doStep`` over [t, t + T).
"""
from fmu_controller.slave import (
    ControllerSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)
from fmu_controller.sotc import W0_BOUND, SotcCore


class SotcController(Fmi2Slave):
    description = "Saturated optimal tracking controller with a single critic and concurrent learning (SOTC)"
    CORE = SotcCore
    # diagnostics of the learning state (weights, CL stack) and of time (probing): no input feedthrough
    STATE_OUTPUTS = tuple(f"W{k}" for k in range(1, 11)) + ("cl_stack_size", "cl_stack_min_eig", "pe_active", "pe")

    def restore_internal_state(self, state) -> None:
        """A restored critic stays in the range of its initial weights (W0_i), and the next CL record
        time between the clock's start and one interval after the restored time."""
        core = state.get("core", {})
        if self._initialized and isinstance(core, dict):
            big = next((w for w in core.get("W", []) if not abs(w) <= W0_BOUND), None)
            if big is not None:
                raise ValueError(f"critic weight {big!r} is outside [-{W0_BOUND:g}, {W0_BOUND:g}] (the range of W0_i)")
            t_next = core.get("next_record_t", 0.0)
            earliest, latest = min(0.0, self._start_time), self._time + self.cl_record_interval
            if not earliest - 1e-9 <= t_next <= latest + 1e-9:
                raise ValueError(f"next_record_t = {t_next!r} is outside [{earliest!r}, {latest!r}] (clock start to "
                                 f"one record interval, parameter 'cl_record_interval' = {self.cl_record_interval!r}, "
                                 "after the state's time)")
        super().restore_internal_state(state)
