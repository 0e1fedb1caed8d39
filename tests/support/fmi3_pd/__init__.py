"""``PdController3.fmu``: the example's PD controller as an FMI 3.0 Co-Simulation FMU in plain C
(``pd_controller3.c`` and ``modelDescription.xml`` beside this file), compiled and zipped by the example's own
``build.py`` (imported as a module and pointed at these files), into the folder FMI 3.0 names a platform's
binaries by (``x86_64-linux``, fmpy's ``platform_tuple``)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import fmpy
import pytest

from support.example_controller import BUILD, compiler

HERE = Path(__file__).resolve().parent
IDENTIFIER = "PdController3"


def build(folder: Path) -> Path:
    if compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the FMI 3.0 PD controller")
    spec = importlib.util.spec_from_file_location("fmi3_pd_build", BUILD)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    headers, _, extension = script._fmpy_headers()
    script.SOURCE, script.DESCRIPTION, script.IDENTIFIER = HERE / "pd_controller3.c", HERE / "modelDescription.xml", \
        IDENTIFIER
    # FMI 3.0's names: the binaries' folder, and the instantiation token in place of the guid
    script._fmpy_headers = lambda: (headers, fmpy.platform_tuple, extension)
    script._guid = lambda: script.ET.parse(script.DESCRIPTION).getroot().get("instantiationToken")
    return script.build(folder)
