"""OtcController: FMI 2.0 and 3.0 co-simulation FMU of the comparison controller (OTC) of the SOTC paper's
section 4, reconstructed from Kong et al. (2021) as documented in docs/baselines.md. Unsaturated
by design. A thin adapter over ``fmu_controller.otc.OtcCore``.
"""
from fmu_controller.otc import OtcCore
from fmu_controller.slave import (
    ControllerSlave as Fmi2Slave,  # the name pythonfmu's binary looks for
)


class OtcController(Fmi2Slave):
    description = "Optimal tracking controller (OTC) after Kong et al. 2021, the paper's comparison controller"
    CORE = OtcCore
    STATE_OUTPUTS = ("wc_norm", "wa_norm")  # norms of the learned weights: no input feedthrough
