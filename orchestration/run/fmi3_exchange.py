"""The Model Exchange interface of an FMI 3.0 FMU in the master (a scenario instance with
``interface = "ModelExchange"``): the master integrates its continuous states over each
communication step [t_k, t_k + T) with fmpy's CVODE (``fmpy.sundials.CVodeSolver``), the inputs held
as set at t_k, like the co-simulation FMU's own integrator does. The solver is restarted at every
t_k, where the held inputs jump, and takes no step longer than T."""
from __future__ import annotations

from types import SimpleNamespace

from fmpy.fmi3 import FMU3Model

from orchestration.run.fmi3_instance import Instance3

REL_TOL = 1e-10  # CVODE's relative tolerance (absolute: the same times each state's nominal, 1)


class ExchangeInstance(Instance3):
    INTERFACE = "modelExchange"

    def _open(self, name: str, log):
        fmu = FMU3Model(guid=self.md.guid, unzipDirectory=self.unzipdir,
                        modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName=name)
        fmu.instantiate(loggingOn=True, logMessage=log)
        self.solver = None
        return fmu

    def initialize(self, stop_time: float) -> None:
        from fmpy.sundials import CVodeSolver

        self.fmu.enterInitializationMode(startTime=0.0, stopTime=stop_time)
        self.fmu.exitInitializationMode()
        update = self.fmu.updateDiscreteStates()
        if update[1]:
            raise RuntimeError(f"{self.name}: the model asked to terminate at its initial event update")
        self.fmu.enterContinuousTimeMode()
        step = float(self.md.defaultExperiment.stepSize) if self.md.defaultExperiment else 0.01
        self.solver = CVodeSolver(
            nx=self.md.numberOfContinuousStates, nz=self.md.numberOfEventIndicators,
            get_x=self.fmu.getContinuousStates, set_x=self.fmu.setContinuousStates,
            get_dx=self.fmu.getContinuousStateDerivatives, get_z=self.fmu.getEventIndicators,
            get_nominals=self.fmu.getNominalsOfContinuousStates, set_time=self.fmu.setTime,
            input=SimpleNamespace(apply=lambda *args, **kwargs: None),  # the master sets the inputs
            startTime=0.0, maxStep=step, relativeTolerance=REL_TOL)

    def do_step(self, t: float, h: float) -> None:
        self.solver.reset(t)  # the held inputs may have jumped at t
        _, _, reached = self.solver.step(t, t + h)
        self.fmu.setTime(t + h)
        if abs(reached - (t + h)) > 1e-9 * max(1.0, abs(t + h)):
            raise RuntimeError(f"{self.name}: CVODE stopped at t = {reached!r} instead of {t + h!r}")
