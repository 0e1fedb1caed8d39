"""Each FMU carries a checked-hash ``.pyc`` (PEP 552) for every bundled module, so that a load compiles
nothing from source (an FMU is extracted into a fresh folder on every load): the ``.pyc``s match their
sources, and a host loading the FMU in a fresh process compiles none of the FMU's modules."""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import zipfile

MAGIC = importlib.util.MAGIC_NUMBER
CHECKED_HASH = 0b11  # PEP 552 flags: hash-based, check_source

COUNT_COMPILES = r"""
import importlib.machinery, shutil, sys, tempfile
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
folder = tempfile.mkdtemp()
compiled = []
real = importlib.machinery.SourceFileLoader.source_to_code
def counting(self, data, path, *args, **kwargs):
    if str(path).startswith(folder):
        compiled.append(path)
    return real(self, data, path, *args, **kwargs)
importlib.machinery.SourceFileLoader.source_to_code = counting
md = read_model_description(sys.argv[1])
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(sys.argv[1], unzipdir=folder),
                modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bytecode")
fmu.instantiate()
fmu.terminate()
fmu.freeInstance()
shutil.rmtree(folder)
print(len(compiled), *compiled)
"""


def test_every_bundled_module_has_a_checked_hash_pyc_of_its_source(fmu_paths):
    with zipfile.ZipFile(fmu_paths["SotcController"]) as z:
        names = set(z.namelist())
        sources = [n for n in names if n.startswith("resources/") and n.endswith(".py")]
        assert sources
        for source in sources:
            folder, _, file = source.rpartition("/")
            pyc = f"{folder}/__pycache__/{file[:-3]}.{sys.implementation.cache_tag}.pyc"
            assert pyc in names, source
            data = z.read(pyc)
            assert data[:4] == MAGIC and int.from_bytes(data[4:8], "little") == CHECKED_HASH, pyc
            assert data[8:16] == importlib.util.source_hash(z.read(source)), pyc


def test_loading_an_fmu_compiles_none_of_its_modules(fmu_paths, tmp_path):
    for model in ("SotcController", "ArmPlant"):
        out = subprocess.run([sys.executable, "-c", COUNT_COMPILES, str(fmu_paths[model])], capture_output=True,
                             text=True, timeout=120, check=True, env={**os.environ, "TMPDIR": str(tmp_path)}).stdout.split()
        assert out[0] == "0", (model, out)
    assert not any(tmp_path.iterdir())  # the FMUs it unpacked are gone (each run left a tmpXXXXXXXX in TMPDIR)
