"""The controller FMUs sotc-cosim ships, in one table: model name, short label, pure core, FMU
script, and the module whose docstring states the equations. The build, the studies, the sweeps and
the summaries all read it here."""
from __future__ import annotations

from dataclasses import dataclass

from fmu_controller.base import ControllerCore
from fmu_controller.computed_torque import CtCore
from fmu_controller.lqr import LqrCore
from fmu_controller.otc import OtcCore
from fmu_controller.sotc import SotcCore


@dataclass(frozen=True)
class Controller:
    model: str  # the FMU's modelIdentifier
    label: str  # short name in tables
    core: type[ControllerCore]
    script: str  # the FMU script, relative to the project root
    equations: str  # the module whose docstring gives the equations


CONTROLLERS: dict[str, Controller] = {c.model: c for c in (
    Controller("SotcController", "SOTC", SotcCore, "fmu_controller/sotc_controller_fmu.py", "fmu_controller/sotc.py"),
    Controller("CtController", "CT", CtCore, "fmu_controller/ct_controller_fmu.py", "fmu_controller/computed_torque.py"),
    Controller("LqrController", "LQR", LqrCore, "fmu_controller/lqr_controller_fmu.py", "fmu_controller/lqr.py"),
    Controller("OtcController", "OTC", OtcCore, "fmu_controller/otc_controller_fmu.py", "fmu_controller/otc.py"),
)}
CORES: dict[str, type[ControllerCore]] = {m: c.core for m, c in CONTROLLERS.items()}
LABELS: dict[str, str] = {m: c.label for m, c in CONTROLLERS.items()}
