"""The FMI 3.0 script of a model: written at build time from its FMI 2.0 script, so an FMI 3 FMU is
the same wrapper class (``fmi3_slave.slave.WrappedSlave`` around it) and nothing is written twice.
The arm also exports Model Exchange (``EXCHANGE``: its mixin, ``fmi3_slave.exchange``).

pythonfmu3 0.3.4's binary imports the script with ``PyErr_Print`` on failure: a ``SystemExit`` raised
while the FMU's code is imported ends the host process (with its code), and any other exception
crashes it (SIGSEGV: it goes on with the module it did not get). So the script imports everything
under a guard (its first statement; the build's header goes inside it, ``packaging.stage``): on any
exception the model class is a stand-in whose instantiation raises ImportError with the reason, which
the binary reports as a failed instantiation, and the host goes on.
"""
from __future__ import annotations

import ast
from pathlib import Path

FMI3_PACKAGE = "fmi3_slave"
# model -> (module, class) of its Model Exchange mixin
EXCHANGE = {"ArmPlant": ("fmu_plant.arm_exchange", "ArmExchange")}


def _guard(model: str, imports: list[str], mixin: str | None) -> str:
    """``imports`` under a ``try`` whose ``except`` binds the names the class statement uses to stand-ins."""
    body = "".join(f"    {line}\n" for line in imports)
    empty_mixin = f"    {mixin} = type({mixin!r}, (), {{}})\n" if mixin else ""
    return ("try:  # pythonfmu3's binary ends or crashes the host when this import raises: a guard\n"
            f"{body}except BaseException as _sotc_failure:  # SystemExit and KeyboardInterrupt too\n"
            f"    _sotc_reason = f\"the {model} FMU's code failed at import: {{type(_sotc_failure).__name__}}: "
            "{_sotc_failure}\"\n\n"
            "    class Fmi3Slave:  # instantiating the FMU fails with the reason\n"
            "        def __init__(self, **kwargs):\n"
            "            raise ImportError(_sotc_reason)\n\n"
            f"    Wrapped = None\n{empty_mixin}")


def script_text(model: str, fmi2_script: Path, root: Path) -> str:
    """The FMI 3 script of ``model`` whose FMI 2 script is ``fmi2_script`` (under ``root``)."""
    module = ".".join(fmi2_script.resolve().relative_to(root.resolve()).with_suffix("").parts)
    doc = ast.get_docstring(ast.parse(fmi2_script.read_text())) or ""
    exchange = EXCHANGE.get(model)
    base = "exchange import ExchangeSlave" if exchange else "slave import WrappedSlave"
    interfaces = "co-simulation and Model Exchange" if exchange else "co-simulation"
    header = (f"{model}: FMI 3.0 {interfaces} FMU, the FMI 2.0 class {module}.{model} presented through "
              f"fmi3_slave (arrays, FMI 3 types).\n\nThe FMI 2.0 script says:\n\n{doc}")
    imports = [f"from {FMI3_PACKAGE}.{base.split()[0]} import {base.split()[-1]} as Fmi3Slave  # the name "
               "pythonfmu3's binary looks for", f"from {module} import {model} as Wrapped"]
    imports += [f"from {exchange[0]} import {exchange[1]}"] if exchange else []
    return (f'"""{header}"""\n{_guard(model, imports, exchange[1] if exchange else None)}\n\n'
            f"class {model}({exchange[1] + ', ' if exchange else ''}Fmi3Slave):\n"
            f"    WRAPPED = Wrapped\n")


def write_script(model: str, fmi2_script: Path, root: Path, folder: Path) -> Path:
    """Write the FMI 3 script of ``model`` into ``folder``; return its path."""
    path = folder / f"{Path(fmi2_script).stem}3.py"
    path.write_text(script_text(model, fmi2_script, root))
    return path
