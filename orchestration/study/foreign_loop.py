"""A controller FMU from any tool in the sampled closed loop with the arm and the reference as cores, in this
process: the loop of the benchmark's trials and held-out evaluation (docs/benchmark.md). The FMU is loaded
once and reset between runs; the arm and the reference are ``pure_loop``'s cores, so a run costs the FMU's
own calls and the cores' arithmetic, with no plant or reference FMU, no recording and no child process.

Per step k (t_k = k T from the step count), what the master does for ``paper`` with the FMU as its
controller (``orchestration.run.master``: read the plant and the reference, set the controller's inputs,
read it, set the plant's input, doStep all), in ``pure_loop``'s arithmetic:

1. the reference r(t_k) (``CircleTrajectory.sample``) and the measurement y_m(t_k) (``Perturbation.measure``:
   the state, plus the noise of draw k under a perturbation);
2. the FMU's mapped inputs set from them with one fmi2SetReal / fmi3SetFloat64 (the master's ``_Inputs``);
3. its outputs read and the actuator applied (``ported.Ported``: the port map, the torques projected onto
   ||tau|| <= rho, the cut flagged); sample k recorded;
4. (k < N) the plant integrated over [t_k, t_k + T) with the torque the arm got plus the disturbance held
   (``dynamics.integrate``), and the FMU's doStep(t_k, T).

So a run equals ``sotc-cosim run`` of the scenario with the FMU as its controller bit for bit
(tests/orchestration/test_foreign_loop.py). Between runs the FMU is reset (fmi2Reset / fmi3Reset), set to
the run's parameters and initialized; an FMU whose reset fails is freed and instantiated again.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from fmpy.fmi1 import FMICallException

from fmu_controller.ports import MEASUREMENT_PORTS, TORQUE_PORTS
from fmu_plant.dynamics import ArmParameters, integrate
from fmu_plant.paper_setting import INITIAL_ANGLES, INITIAL_VELOCITIES, STEP_SIZE, SUBSTEPS, TORQUE_LIMIT
from fmu_plant.perturbation import NoiseSequence
from fmu_plant.trajectory import REFERENCE_SIGNALS, CircleTrajectory
from orchestration.run import master
from orchestration.run.metrics import TORQUE_CUT
from orchestration.run.ported import Ported
from orchestration.study.pure_loop import NO_PERTURBATION, LoopResult, Perturbation, steps

UNDISTURBED = (0.0, 0.0)
NAME = "controller"  # the instance's name, as in a scenario (its log records carry it)
SET, GET, STEP = ((NAME, kind) for kind in ("set", "get", "step"))  # the call under way, as the master's clock has it


@dataclass
class ForeignResult(LoopResult):
    """``pure_loop.LoopResult`` of one run (``outputs``: ``tau1 tau2``, what the arm got, then the FMU's own
    outputs, then ``torque_cut``), and the samples whose torques the actuator cut."""

    cuts: int = 0


def _undisturbed(t: float) -> tuple[float, float]:
    """``Perturbation.disturbance`` where it does not disturb: the same (0.0, 0.0), without its sine."""
    return UNDISTURBED


class _Samples:
    """The plant's and the reference's samples at t_k as the master's source instances hold them: one buffer,
    the measurement then the reference's signals, which the master's ``_Inputs`` sets the FMU's inputs from."""

    name = "cores"
    output_names = [*MEASUREMENT_PORTS, *REFERENCE_SIGNALS]

    def __init__(self):
        self.out_buf = (ctypes.c_double * len(self.output_names))()
        self.out_view = np.ctypeslib.as_array(self.out_buf)


class ForeignLoop:
    """The controller FMU ``fmu_file`` (FMI 2.0 or 3.0 co-simulation) under the port map ``ports`` (None: its
    variables of the contract's names), loaded once, its torques bounded to ``bound``; ``run`` runs it from a
    point. ``reinstantiated`` counts the resets that failed. ``clock`` (a ``master._Clock``) is kept at the
    sample and the FMI call under way, as the master keeps it. Close it (or use it in a ``with``) to free it."""

    def __init__(self, fmu_file: Path, ports: dict[str, str] | None = None, bound: float = TORQUE_LIMIT,
                 clock: master._Clock | None = None):
        self.fmu_file, self.ports, self.bound = Path(fmu_file), ports, bound
        self.logs: list[master.LogRecord] = []
        self.clock = clock if clock is not None else master._Clock()
        self.samples = _Samples()
        self.reinstantiated = 0
        self.ported: Ported | None = None
        self._open()

    def _open(self) -> None:
        """Instantiate the FMU as the master does (``master._instance``, ``Ported``) and plan its inputs."""
        inner = master._instance(SimpleNamespace(name=NAME, interface="CoSimulation"), self.fmu_file, self.logs,
                                 self.clock)
        try:
            self.ported = ported = Ported(inner, self.ports, self.bound)
        except Exception:
            master._free({NAME: inner})
            raise
        pairs = [(n, n) for n in self.samples.output_names if n in ported.inputs]
        self.push = master._Inputs(ported, [master._Link(self.samples, ported, pairs)]).push if pairs else None
        n = len(ported.inner.output_names)
        self.tau = (n, n + 1)  # where the torques the arm gets are in the ported outputs, the cut after them
        self.fresh = True

    def _restart(self) -> None:
        """The state after instantiation: fmi2Reset / fmi3Reset, or where that fails, a new instance."""
        if self.fresh:
            return
        self.ported.initialized = False
        try:
            self.ported.fmu.reset()
        except FMICallException:
            self.close()
            self.reinstantiated += 1
            self._open()

    def run(self, parameters: dict[str, float] | None = None, stop_time: float = 100.0, step: float = STEP_SIZE,
            arm: ArmParameters | None = None, trajectory: CircleTrajectory | None = None,
            phi0: tuple[float, float] = INITIAL_ANGLES, dphi0: tuple[float, float] = INITIAL_VELOCITIES,
            substeps: int = SUBSTEPS, perturbation: Perturbation = NO_PERTURBATION) -> ForeignResult:
        """One closed-loop run (module docstring) with the FMU's ``parameters`` set, from section 4's initial
        state by default (``pure_loop.simulate``'s arguments). A refusal of the FMU raises ``FMICallException``
        and one of the arm ``IntegrationError``, as ``pure_loop.simulate`` raises; the next run resets the FMU.
        ``logs`` holds this run's log records of the FMU (its sample stamped, -1 while it is set up)."""
        if self.ported is None:
            raise ValueError(f"{self.fmu_file}: the loop was closed")
        n = steps(stop_time, step)
        self.logs.clear()  # the sinks hold this list: one run's records at a time, however many runs
        self.clock.sample = -1
        self._restart()
        self.fresh = False
        ported = self.ported
        ported.set_parameters(parameters or {})
        ported.initialize(stop_time)
        ported.initialized = True
        arm = arm if arm is not None else ArmParameters()
        trajectory = trajectory if trajectory is not None else CircleTrajectory()
        ys, refs = np.empty((n + 1, 4)), np.empty((n + 1, len(REFERENCE_SIGNALS)))
        outs = np.empty((n + 1, len(ported.output_names)))
        self._loop(n, step, (float(phi0[0]), float(phi0[1]), float(dphi0[0]), float(dphi0[1])),
                   (arm, trajectory, substeps, perturbation), (ys, refs, outs))
        return self._result(n, step, ys, refs, outs)

    def _loop(self, n: int, step: float, state: tuple, model: tuple, records: tuple) -> None:
        """The hot loop: everything looked up once, no per-step allocation of ours beyond the cores' tuples."""
        arm, trajectory, substeps, perturbation = model
        ys, refs, outs = records
        sample, measure = trajectory.sample, perturbation.measure
        disturbance = perturbation.disturbance if perturbation.disturbs else _undisturbed
        noise = NoiseSequence(perturbation.seed)
        ported, push, src, clock = self.ported, self.push, self.samples.out_buf, self.clock
        read, do_step, out, view = ported.read_outputs, ported.do_step, ported.out_buf, ported.out_view
        i1, i2 = self.tau
        for k in range(n + 1):
            t = k * step
            clock.sample = k
            ref = sample(t)
            src[0:4] = measure(state, noise, k)
            src[4:] = ref
            if push is not None:
                clock.call = SET
                push()
            clock.call = GET
            read()
            ys[k] = state
            refs[k] = ref
            outs[k] = view
            if k == n:
                return
            d1, d2 = disturbance(t)
            state = integrate(state, out[i1] + d1, out[i2] + d2, step, substeps, arm)
            clock.call = STEP
            do_step(t, step)

    def _result(self, n: int, step: float, ys: np.ndarray, refs: np.ndarray, outs: np.ndarray) -> ForeignResult:
        names = self.ported.output_names
        order = [names.index(k) for k in TORQUE_PORTS] + [i for i, k in enumerate(names) if k not in TORQUE_PORTS]
        cuts = int(np.count_nonzero(outs[:, names.index(TORQUE_CUT)]))
        return ForeignResult(np.arange(n + 1, dtype=float) * step, ys, refs, outs[:, order],
                             tuple(names[i] for i in order), cuts=cuts)

    def close(self) -> None:
        """Free the FMU (terminated first if it was initialized), as the master frees its instances."""
        if self.ported is not None:
            master._free({NAME: self.ported})
            self.ported = None

    def __enter__(self) -> "ForeignLoop":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
