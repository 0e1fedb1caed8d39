"""Reproduce the `corrupted double-linked list` abort at exit (docs/interop.md).

usage: python docs/repro/free_abort.py FMU_FILE [N] [--host-imports-scipy] [--no-free]

Loads N instances (default 3) of FMU_FILE through fmpy, each from its own extracted folder, steps
each five times, terminates and frees them, and exits normally; run it 20 times and count non-zero
exit codes (134 = the abort).
"""
import sys
import tempfile

if "--host-imports-scipy" in sys.argv:
    import scipy.linalg  # noqa: F401  (the workaround: SciPy loaded by the host, not inside the FMU)

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

args = [a for a in sys.argv[1:] if not a.startswith("--")]
fmu, n = args[0], int(args[1]) if len(args) > 1 else 3
md = read_model_description(fmu)
units = []
for i in range(n):
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu, unzipdir=tempfile.mkdtemp()),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"i{i}")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    for k in range(5):
        f.doStep(k * 0.01, 0.01)
    f.terminate()
    units.append(f)
if "--no-free" not in sys.argv:
    for f in units:
        f.freeInstance()
print("freed", flush=True)
