"""The arm as FMI 3.0 Model Exchange: continuous states phi and dphi, their derivatives dphi and
ddphi = D^-1 (tau + d - H dphi - G) from ``fmu_plant.dynamics.forward_dynamics`` (eq. (1)/(46), the
formula the co-simulation arm's RK4 integrates), the torques tau and d held as the host sets them.

A mixin of the FMI 3 ``ArmPlant`` (with ``fmi3_slave.exchange.ExchangeSlave``), over the FMI 2
``fmu_plant.arm_plant_fmu.ArmPlant`` it wraps (``_inner``): no FMI import here.
"""
from __future__ import annotations

from fmu_plant.dynamics import forward_dynamics


class ArmExchange:
    STATE_ARRAYS = ("phi", "dphi")

    def state_derivatives(self) -> list[float]:
        arm = self._inner
        a1, a2 = forward_dynamics(arm.phi2, arm.dphi1, arm.dphi2, arm.tau1 + arm.d1, arm.tau2 + arm.d2, arm._arm)
        return [arm.dphi1, arm.dphi2, a1, a2]

    def set_states(self, values: list[float]) -> None:
        self._inner._set_state(*values)  # the outputs (angles, positions) follow the state
