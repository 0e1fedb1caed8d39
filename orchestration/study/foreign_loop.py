"""A controller FMU from any tool in the sampled closed loop with the arm and the reference as cores, in this
process: the loop of the benchmark's trials and held-out evaluation (docs/benchmark.md). The FMU is loaded
once and reset between runs; the arm and the reference are ``pure_loop``'s cores, so a run costs the FMU's
own calls and the cores' arithmetic, with no plant or reference FMU, no recording and no child process.

Per step k (t_k = k T from the step count), what the master does for ``paper`` with the FMU as its
controller (``orchestration.run.master``: read the plant and the reference, set the controller's inputs,
read it, set the plant's input, doStep all), in ``pure_loop``'s arithmetic:

1. the reference r(t_k) (``CircleTrajectory.sample``, whose samples are the same for every run of one
   trajectory and length: taken once for them) and the measurement y_m(t_k) (``Perturbation.measure``: the
   state, plus the noise of draw k under a perturbation);
2. the FMU's mapped inputs set from them with one fmi2SetReal / fmi3SetFloat64 (the master's ``_Inputs``);
3. its outputs read with one fmi2GetReal / fmi3GetFloat64 and the actuator applied as ``ported.Ported`` applies
   it (its port map; the torques projected onto ||tau|| <= rho by ``saturate_norm``; the cut flags,
   ``ported.cut_flag``, set for the whole run at its end); sample k recorded;
4. (k < N) the plant integrated over [t_k, t_k + T) with the torque the arm got plus the disturbance held
   (``dynamics.integrate``), and the FMU's doStep(t_k, T).

The loop makes the FMU's calls itself, through the instance's raw ctypes functions, rather than through the
master's per-call wrappers (``Ported.read_outputs``, ``do_step``): a C controller's own calls cost about 1 us,
and the wrappers' lookups, numpy copies and numpy scalars cost more than that (``sotc-cosim bench``,
docs/benchmark.md). So a run equals ``sotc-cosim run`` of the scenario with the FMU as its controller bit for bit
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
from fmpy.fmi2 import fmi2OK, fmi2True, fmi2Warning

from fmu_controller.ports import MEASUREMENT_PORTS, TORQUE_PORTS
from fmu_controller.saturation import saturate_norm
from fmu_plant.dynamics import ArmParameters, integrate
from fmu_plant.paper_setting import INITIAL_ANGLES, INITIAL_VELOCITIES, STEP_SIZE, SUBSTEPS, TORQUE_LIMIT
from fmu_plant.perturbation import NoiseSequence
from fmu_plant.trajectory import REFERENCE_SIGNALS, CircleTrajectory
from orchestration.run import child, master
from orchestration.run.metrics import TORQUE_CUT
from orchestration.run.ported import Ported, cut_flag
from orchestration.study.pure_loop import NO_PERTURBATION, LoopResult, Perturbation, steps

NAME = "controller"  # the instance's name, as in a scenario (its log records carry it)
SET, GET, STEP = ((NAME, kind) for kind in ("set", "get", "step"))  # the call under way, as the master's clock has it
ACTED = 4  # per sample, what ``saturate_norm`` returned: the torques the arm gets, the norm, whether it moved them


@dataclass
class ForeignResult(LoopResult):
    """``pure_loop.LoopResult`` of one run (``outputs``: ``tau1 tau2``, what the arm got, then the FMU's own
    outputs, then ``torque_cut``; without ``samples``, ``tau1 tau2 torque_cut``), and the samples whose torques
    the actuator cut."""

    cuts: int = 0


class _Samples:
    """The plant's and the reference's samples at t_k as the master's source instances hold them: one buffer,
    the measurement then the reference's signals, which the master's ``_Inputs`` sets the FMU's inputs from."""

    name = "cores"
    output_names = [*MEASUREMENT_PORTS, *REFERENCE_SIGNALS]

    def __init__(self):
        self.out_buf = (ctypes.c_double * len(self.output_names))()
        self.out_view = np.ctypeslib.as_array(self.out_buf)


def _converted(function, args: tuple) -> tuple:
    """An FMI function of fmpy's (a ctypes function with its argument types declared) for a call whose ``args``
    never change: the same C function without the declared types, and ``args`` converted once as those types
    convert them (``from_param``), which ctypes would otherwise do at every call, argument by argument (half of
    what a C controller's set or get costs). Anything else (``Instance3.raw_set``, a Python function) as it is."""
    if getattr(function, "argtypes", None) is None:
        return function, args
    bare = type(function)(ctypes.cast(function, ctypes.c_void_p).value)
    bare.restype = function.restype
    return bare, tuple(kind.from_param(a) for kind, a in zip(function.argtypes, args, strict=True))


def _pushed(push):
    """``master._Inputs.push`` (inputs gathered from several places of the sources' buffer) in the shape of a raw
    set call: it raises on a bad status itself, so what reaches the loop is OK."""
    def call() -> int:
        push()
        return fmi2OK
    return call


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
        self._reference: tuple = (None, [], np.empty((0, len(REFERENCE_SIGNALS))))
        self._open()

    def _open(self) -> None:
        """Instantiate the FMU as the master does (``master._instance``, ``Ported``) and plan its calls: each the
        instance's raw ctypes function (``Instance2``'s; ``Instance3``'s in the same shape) with the arguments
        that do not change built once, and its name for a bad status (``child.call_name``)."""
        inner = master._instance(SimpleNamespace(name=NAME, interface="CoSimulation"), self.fmu_file, self.logs,
                                 self.clock)
        try:
            self.ported = ported = Ported(inner, self.ports, self.bound)
        except Exception:
            master._free({NAME: inner})
            raise
        pairs = [(n, n) for n in self.samples.output_names if n in ported.inputs]
        inputs = master._Inputs(ported, [master._Link(self.samples, ported, pairs)]) if pairs else None
        if inputs is None:
            sets = None, ()
        elif inputs.parts:  # gathered from several places of the samples: the master's own push
            sets = _pushed(inputs.push), ()
        else:  # read where the samples are, no copy
            sets = inputs.raw_set, inputs.set_args
        # doStep stays fmpy's function as it is: the bench subtracts its cost per call, made the same way
        self.calls = (*_converted(*sets), *_converted(inner.raw_get, inner.get_args), inner.raw_step,
                      inner.fmu.component,
                      tuple(child.call_name(kind, inner.md.fmiVersion) for kind in ("set", "get", "step")))
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
            substeps: int = SUBSTEPS, perturbation: Perturbation = NO_PERTURBATION,
            samples: bool = True) -> ForeignResult:
        """One closed-loop run (module docstring) with the FMU's ``parameters`` set, from section 4's initial
        state by default (``pure_loop.simulate``'s arguments). A refusal of the FMU raises ``FMICallException``
        and one of the arm ``IntegrationError``, as ``pure_loop.simulate`` raises; the next run resets the FMU.
        ``logs`` holds this run's log records of the FMU (its sample stamped, -1 while it is set up).
        ``samples=False`` (a trial's run: ``pure_loop.metrics`` and the cuts are all it reads) leaves out the
        FMU's own outputs, the one record whose size the FMU decides; every other sample is the same."""
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
        records = (np.empty((n + 1, 4)), np.empty((n + 1, ACTED)),
                   np.empty((n + 1, ported.n_own)) if samples else None)
        refs = self._references(trajectory, step, n)
        self._loop(n, step, (float(phi0[0]), float(phi0[1]), float(dphi0[0]), float(dphi0[1])),
                   (arm, refs[0], substeps, perturbation), records)
        return self._result(n, step, records[0], refs[1].copy(), *records[1:])

    def _references(self, trajectory: CircleTrajectory, step: float, n: int) -> tuple[list, np.ndarray]:
        """The reference's samples r(t_0) .. r(t_N) (``CircleTrajectory.sample``'s tuples, and as an array): the
        same for every run of one trajectory, step and length, as a trial's runs all are, so sampled once for them
        (the last ones kept) instead of at every step of every run."""
        key = (trajectory, step, n)
        if self._reference[0] != key:
            samples = [trajectory.sample(k * step) for k in range(n + 1)]
            self._reference = (key, samples, np.array(samples, dtype=float))
        return self._reference[1:]

    def _loop(self, n: int, step: float, state: tuple, model: tuple, records: tuple) -> None:
        """The hot loop: the FMU's raw calls with their arguments built once (``_open``), its torques read from
        its buffer as Python floats, each record one slice of a preallocated array written through a ctypes view
        of it (a numpy row from a tuple costs several times as much), the clock marked as ``clock.marks`` says
        (one item each); no allocation of ours per step, only the cores' tuples."""
        arm, references, substeps, perturbation = model
        ys, acts = (np.ctypeslib.as_ctypes(a.reshape(-1)) for a in records[:2])
        own = records[2]
        measure, noisy = perturbation.measure, perturbation.noisy
        disturbance, disturbs, noise = perturbation.disturbance, perturbation.disturbs, NoiseSequence(perturbation.seed)
        marks, at_sample, at_call, (on_set, on_get, on_step) = self.clock.marks((SET, GET, STEP))
        set_call, set_args, get_call, get_args, step_call, component, names = self.calls
        src, out, own_view = self.samples.out_buf, self.ported.inner.out_buf, self.ported.inner.out_view
        (i1, i2), bound, warning = self.ported.torque_index, self.bound, fmi2Warning
        d1 = d2 = 0.0
        for k in range(n + 1):
            t = k * step
            marks[at_sample] = k
            src[0:4] = measure(state, noise, k) if noisy else state
            src[4:] = references[k]
            if set_call is not None:
                marks[at_call] = on_set
                status = set_call(*set_args)
                if status > warning:
                    raise FMICallException(function=names[0], status=status)
            marks[at_call] = on_get
            status = get_call(*get_args)
            if status > warning:
                raise FMICallException(function=names[1], status=status)
            acted = saturate_norm(out[i1], out[i2], bound)
            j = ACTED * k
            acts[j:j + ACTED] = acted
            ys[j:j + 4] = state
            if own is not None:
                own[k] = own_view
            if k == n:
                return
            if disturbs:
                d1, d2 = disturbance(t)
            state = integrate(state, acted[0] + d1, acted[1] + d2, step, substeps, arm)
            marks[at_call] = on_step
            status = step_call(component, t, step, fmi2True)
            if status > warning:
                raise FMICallException(function=names[2], status=status)

    def _result(self, n: int, step: float, ys: np.ndarray, refs: np.ndarray, acts: np.ndarray,
                own: np.ndarray | None) -> ForeignResult:
        """The records as the master's columns: the torques the arm got, the FMU's own outputs (with samples),
        the cut flags (``ported.cut_flag`` on the whole run)."""
        ported = self.ported
        flags = cut_flag(acts[:, 3] != 0.0, acts[:, 2], ported.cut_above)
        columns, names = [acts[:, :2]], list(TORQUE_PORTS)
        if own is not None:
            columns.append(own)
            names += ported.output_names[:ported.n_own]
        return ForeignResult(np.arange(n + 1, dtype=float) * step, ys, refs, np.column_stack([*columns, flags]),
                             (*names, TORQUE_CUT), cuts=int(np.count_nonzero(flags)))

    def close(self) -> None:
        """Free the FMU (terminated first if it was initialized), as the master frees its instances."""
        if self.ported is not None:
            master._free({NAME: self.ported})
            self.ported = None

    def __enter__(self) -> "ForeignLoop":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
