"""The FMI 3.0 script of a model: written at build time from its FMI 2.0 script, so an FMI 3 FMU is
the same wrapper class (``fmi3_slave.slave.WrappedSlave`` around it) and nothing is written twice.
The arm also exports Model Exchange (``EXCHANGE``: its mixin, ``fmi3_slave.exchange``)."""
from __future__ import annotations

import ast
from pathlib import Path

FMI3_PACKAGE = "fmi3_slave"
# model -> (module, class) of its Model Exchange mixin
EXCHANGE = {"ArmPlant": ("fmu_plant.arm_exchange", "ArmExchange")}


def script_text(model: str, fmi2_script: Path, root: Path) -> str:
    """The FMI 3 script of ``model`` whose FMI 2 script is ``fmi2_script`` (under ``root``)."""
    module = ".".join(fmi2_script.resolve().relative_to(root.resolve()).with_suffix("").parts)
    doc = ast.get_docstring(ast.parse(fmi2_script.read_text())) or ""
    exchange = EXCHANGE.get(model)
    base = "exchange import ExchangeSlave" if exchange else "slave import WrappedSlave"
    mixin = f"from {exchange[0]} import {exchange[1]}\n" if exchange else ""
    interfaces = "co-simulation and Model Exchange" if exchange else "co-simulation"
    header = (f"{model}: FMI 3.0 {interfaces} FMU, the FMI 2.0 class {module}.{model} presented through "
              f"fmi3_slave (arrays, FMI 3 types).\n\nThe FMI 2.0 script says:\n\n{doc}")
    return (f'"""{header}"""\n'
            f"from {FMI3_PACKAGE}.{base.split()[0]} import {base.split()[-1]} as Fmi3Slave  # the name pythonfmu3's binary looks for\n"
            f"from {module} import {model} as Wrapped\n{mixin}\n\n"
            f"class {model}({exchange[1] + ', ' if exchange else ''}Fmi3Slave):\n"
            f"    WRAPPED = Wrapped\n")


def write_script(model: str, fmi2_script: Path, root: Path, folder: Path) -> Path:
    """Write the FMI 3 script of ``model`` into ``folder``; return its path."""
    path = folder / f"{Path(fmi2_script).stem}3.py"
    path.write_text(script_text(model, fmi2_script, root))
    return path
