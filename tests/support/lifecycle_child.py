"""Child process of test_fmu_lifecycle: legal (and refused-then-recovered) call sequences on every
FMU given on the command line. A reference-count slip in the pythonfmu binary shows only as a crash
at interpreter exit, so the parent checks this process's exit code.

usage: python -m support.lifecycle_child WORKDIR FMU...  (tests/ on PYTHONPATH: support.child_env)
"""
import itertools
import math
import sys
from pathlib import Path

from fmpy.fmi1 import FMICallException

from fmu_plant.dynamics import STEP_SIZE as T
from support.fmu_driver import DrivenFmu

_count = itertools.count()


def new(fmu, workdir):
    return DrivenFmu(Path(fmu), Path(workdir) / f"i{next(_count)}", instance_name=f"i{next(_count)}")


def steps(u, n, k0=0):
    for k in range(k0, k0 + n):
        u.fmu.doStep(k * T, T)


def refused_init(u):
    bad = next(v.name for v in u.md.modelVariables if v.causality == "parameter" and v.type == "Real")
    u.set(**{bad: math.nan})
    u.fmu.setupExperiment(startTime=0.0)
    u.fmu.enterInitializationMode()
    try:
        u.fmu.exitInitializationMode()
    except FMICallException:
        return
    raise AssertionError("a NaN parameter was accepted")


def sequences(fmu, w):
    u = new(fmu, w)  # instantiate -> free
    u.free()

    u = new(fmu, w)  # initialized, never stepped, never terminated
    u.initialize()
    u.free()

    u = new(fmu, w)  # the usual run
    u.initialize()
    steps(u, 3)
    u.fmu.terminate()
    u.free()

    u = new(fmu, w)  # terminate, read, reset, run again
    u.initialize()
    steps(u, 2)
    u.fmu.terminate()
    u.fmu.getReal([0])
    u.fmu.reset()
    u.initialize()
    steps(u, 2)
    u.fmu.terminate()
    u.free()

    u = new(fmu, w)  # refused initialization, then freed
    refused_init(u)
    u.free()

    u = new(fmu, w)  # refused initialization, reset, proper run
    refused_init(u)
    u.fmu.reset()
    u.initialize()
    steps(u, 2)
    u.fmu.terminate()
    u.free()

    u = new(fmu, w)  # a refused call mid-run, then the run goes on
    u.initialize()
    steps(u, 1)
    param = next(v for v in u.md.modelVariables if v.causality == "parameter" and v.type == "Real")
    try:
        u.fmu.setReal([param.valueReference], [float(param.start) + 1.0])
        raise AssertionError("a fixed parameter changed after initialization")
    except FMICallException:
        pass
    steps(u, 2, k0=1)
    u.fmu.terminate()
    u.free()

    u = new(fmu, w)  # an FMU state still allocated when the instance is freed
    u.initialize()
    steps(u, 1)
    u.fmu.getFMUState()
    u.free()

    a, b = new(fmu, w), new(fmu, w)  # two instances, freed in the order they were not created
    a.initialize()
    b.initialize()
    steps(a, 2)
    steps(b, 1)
    b.fmu.terminate()
    b.free()
    steps(a, 1, k0=2)
    a.fmu.terminate()
    a.free()


def main() -> int:
    workdir, fmus = sys.argv[1], sys.argv[2:]
    for fmu in fmus:
        sequences(fmu, workdir)
        print(f"{Path(fmu).stem}: ok", flush=True)
    print("all sequences ok", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
