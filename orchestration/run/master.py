"""The fixed-step co-simulation master: loads FMUs with fmpy, connects them, steps them, records.

Call order at each communication point t_k = k T (k = 0 .. N, computed as k * T, never summed):

1. for each instance in feedthrough order: read all its outputs, then set the inputs of every
   instance whose sources have all been read now (one fmi2SetReal per target instance);
2. record every output of every instance at t_k;
3. (k < N) ``doStep(t_k, T)`` on every instance.

"Feedthrough order" is a topological order of the instances over connections whose target has
outputs that depend directly on its inputs (declared in modelDescription ``ModelStructure/Outputs``
``dependencies``). The plant and the reference declare none, so they are read first; a controller
declares that its torque depends on its inputs, so it is read after its inputs were set from the
plant and reference at t_k. The torque read at t_k is therefore computed from the measurement at
t_k, and the plant's doStep holds it over [t_k, t_k + T): the paper's sampled, zero-order-hold loop.
An algebraic loop (a cycle of feedthrough) is refused before the run starts.
"""
from __future__ import annotations

import ctypes
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, Sequence

import numpy as np
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2Real, fmi2ValueReference, fmi2Warning

from orchestration.run import interrupt
from orchestration.run.fmi2_instance import Instance2
from orchestration.run.fmi_direct import forget_callbacks
from orchestration.run.parameter_check import model_description
from orchestration.run.ported import Ported
from orchestration.run.scenario import Scenario, ScenarioError

STATUS_LABELS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")


@dataclass
class LogRecord:
    instance: str
    status: str
    message: str
    sample: int = -1  # the sample k whose output reads or doStep(t_k) logged it; -1 during set-up


@dataclass
class RunResult:
    """Everything a run produced. With ``keep_samples`` (the default) ``outputs[instance][variable]``
    has one value per sample and ``time`` every sample time; a streamed run (``keep_samples=False``)
    leaves both empty: its observers saw every sample, and ``samples`` still counts them."""

    scenario: Scenario
    time: np.ndarray
    outputs: dict[str, dict[str, np.ndarray]]
    wall_time_s: float
    failed: bool = False
    error: str | None = None
    interrupted: bool = False  # stopped by SIGINT, SIGTERM or SIGHUP (``orchestration.run.interrupt``); ``failed`` is set too
    logs: list[LogRecord] = field(default_factory=list)
    # every parameter of every instance as the FMU holds it after initialization (defaults included)
    parameters: dict[str, dict[str, float]] = field(default_factory=dict)
    # per instance, the identity of the FMU it ran: guid, version, generation_tool (modelDescription)
    fmus: dict[str, dict[str, str]] = field(default_factory=dict)
    completed: int | None = None  # samples t_0 .. t_{completed-1} were produced (None: len(time))

    @property
    def samples(self) -> int:
        return len(self.time) if self.completed is None else self.completed


class RunObserver(Protocol):
    """Receives a run while it happens (e.g. the Rerun recorder), in blocks of samples.

    ``start`` gets each instance's output names and the parameter values every instance runs with
    (read back from the FMUs, defaults included); ``block`` gets the sample times and, per
    instance, an array (m, n_outputs) of the samples since the previous block (views: copy what
    must outlive the call); ``finish`` gets the complete result, also after a failure.
    """

    def start(self, scenario: Scenario, columns: dict[str, list[str]], parameters: dict[str, dict[str, float]]) -> None: ...

    def block(self, time: np.ndarray, rows: dict[str, np.ndarray]) -> None: ...

    def finish(self, result: "RunResult") -> None: ...


class _ObserverFailed(Exception):
    """The observer raised: the run stops, and the observer is not handed that data again."""


class _Clock:
    """The sample the run is at, for stamping log messages (-1 during set-up), and the call under way,
    (instance, "get" | "set" | "step"), which ``orchestration.run.isolated`` shares with its parent."""

    sample = -1
    call = ("", "")

    def marks(self, calls: Sequence[tuple[str, str]]) -> tuple:
        """For a loop that marks every call and cannot afford a property per mark (``foreign_loop``): (store,
        sample key, call key, each of ``calls`` as stored), so that ``store[sample_key] = k`` is ``sample = k``
        and ``store[call_key] = stored[i]`` is ``call = calls[i]``; here the instance's own attributes."""
        return vars(self), "sample", "call", tuple(calls)


class _LogSink:
    """Turns one instance's (status, message) log entries into the run's LogRecords."""

    def __init__(self, instance: str, logs: list[LogRecord], clock: _Clock):
        self.instance, self.logs, self.clock = instance, logs, clock

    def append(self, entry: tuple[int, str]) -> None:
        status, message = entry
        label = STATUS_LABELS[status] if 0 <= status < len(STATUS_LABELS) else str(status)
        self.logs.append(LogRecord(self.instance, label, message, self.clock.sample))


def _instance(inst, fmu_file: Path, logs: list[LogRecord], clock: _Clock):
    """The instance of an FMI 2.0 FMU (``fmi2_instance``) or of an FMI 3.0 one (``fmi3_instance``; ``fmi3_exchange``
    for its Model Exchange interface): one interface, each handed the model description parsed once here."""
    md = model_description(fmu_file)  # parsed once per FMU file (runs, sweep points, the CLI's check)
    fmi3 = md.fmiVersion.startswith("3")
    sink = _LogSink(inst.name, logs, clock)
    if inst.interface == "ModelExchange":
        if not fmi3:
            raise ScenarioError(f"instance '{inst.name}': interface = \"ModelExchange\" needs an FMI 3.0 FMU; "
                                f"{fmu_file} is FMI 2.0 (run with --fmi 3)")
        from orchestration.run.fmi3_exchange import ExchangeInstance

        return ExchangeInstance(inst.name, fmu_file, md, sink)
    if fmi3:
        from orchestration.run.fmi3_instance import Instance3

        return Instance3(inst.name, fmu_file, md, sink)
    return Instance2(inst.name, fmu_file, md, sink)


class _Link:
    """All connections from one source instance to one target instance."""

    def __init__(self, source: Instance2, target: Instance2, pairs: list[tuple[str, str]]):
        self.source, self.target = source, target
        self.src_index = np.array([source.output_names.index(o) for o, _ in pairs], dtype=np.intp)
        self.target_vrs = [target.vars[i].valueReference for _, i in pairs]


class _Inputs:
    """Every connection into one target instance, set with one fmi2SetReal from preallocated buffers
    once all its sources have been read at the communication point. When the inputs are one run of
    consecutive outputs of a single source (the arm's torques), the call reads them where the source's
    outputs were read into: nothing is copied."""

    def __init__(self, target: Instance2, links: list[_Link]):
        self.target, self.raw_set = target, target.raw_set
        vrs = [vr for link in links for vr in link.target_vrs]
        self.n = len(vrs)
        self.vr = (fmi2ValueReference * self.n)(*vrs)
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        first = links[0].src_index
        if len(links) == 1 and np.array_equal(first, np.arange(first[0], first[0] + self.n)):
            self.source_buf = links[0].source.out_buf  # kept alive with the view into it
            offset = int(first[0]) * ctypes.sizeof(fmi2Real)
            self.buf = (fmi2Real * self.n).from_address(ctypes.addressof(self.source_buf) + offset)
        else:
            self.buf = (fmi2Real * self.n)()
            view, lo = np.ctypeslib.as_array(self.buf), 0
            for link in links:  # (source outputs, which of them, where they go in the buffer)
                self.parts.append((link.source.out_view, link.src_index, view[lo:lo + len(link.src_index)]))
                lo += len(link.src_index)
        self.set_args = (target.fmu.component, self.vr, self.n, self.buf)  # looked up once, not per call

    def push(self) -> None:
        for outputs, index, into in self.parts:
            outputs.take(index, out=into)  # no per-step allocation
        status = self.raw_set(*self.set_args)
        if status > fmi2Warning:
            raise FMICallException(function="fmi2SetReal", status=status)


def _input_pushes(order: list[str], links: list[_Link]) -> dict[str, list[_Inputs]]:
    """Per instance, the targets whose inputs are set right after it is read: those whose last
    source (in ``order``) it is, so each target gets one fmi2SetReal per communication point."""
    position = {name: i for i, name in enumerate(order)}
    by_target: dict[str, list[_Link]] = {}
    for link in links:
        by_target.setdefault(link.target.name, []).append(link)
    pushes: dict[str, list[_Inputs]] = {name: [] for name in order}
    for target_links in by_target.values():
        last = max((link.source.name for link in target_links), key=position.__getitem__)
        pushes[last].append(_Inputs(target_links[0].target, target_links))
    return pushes


def _resolve_links(scenario: Scenario, loaded: dict[str, Instance2]) -> list[_Link]:
    """The scenario's connections grouped by (source, target) instance pair."""
    connections = scenario.resolve_connections(
        {n: ld.output_names for n, ld in loaded.items()}, {n: ld.inputs for n, ld in loaded.items()})
    pairs: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for c in connections:
        pairs.setdefault((c.source, c.target), []).append((c.output, c.input))
    return [_Link(loaded[s], loaded[d], p) for (s, d), p in pairs.items()]


def _feedthrough_order(loaded: dict[str, Instance2], links: list[_Link]) -> list[str]:
    """Instances ordered so that each feedthrough instance comes after every instance feeding it."""
    deps = {name: set() for name in loaded}
    for link in links:
        if link.target.feedthrough:
            deps[link.target.name].add(link.source.name)
    order: list[str] = []
    while deps:
        ready = sorted(n for n, d in deps.items() if not d - set(order))
        if not ready:
            raise ScenarioError(f"algebraic loop between feedthrough instances: {sorted(deps)}")
        for n in ready:
            order.append(n)
            del deps[n]
    return order


class _Fanout:
    """Several observers as one, called in order."""

    def __init__(self, observers: Sequence[RunObserver]):
        self.observers = list(observers)

    def start(self, scenario, columns, parameters) -> None:
        for o in self.observers:
            o.start(scenario, columns, parameters)

    def block(self, time, rows) -> None:
        for o in self.observers:
            o.block(time, rows)

    def finish(self, result) -> None:
        for o in self.observers:
            o.finish(result)


class _Session:
    """One run: the loaded instances, one sample buffer per instance, and how far the samples were
    recorded and handed to the observer."""

    def __init__(self, scenario: Scenario, observer, block_size: int, keep_samples: bool, clock: _Clock | None):
        self.scenario, self.observer, self.block_size, self.keep = scenario, observer, block_size, keep_samples
        self.logs: list[LogRecord] = []
        self.clock = clock or _Clock()
        self.parameters: dict[str, dict[str, float]] = {}
        self.fmus: dict[str, dict[str, str]] = {}
        n_steps = scenario.steps
        self.rows = n_steps + 1 if keep_samples else min(block_size, n_steps + 1)  # rows held per instance
        self.times = np.arange(n_steps + 1, dtype=float) * scenario.step_size if keep_samples else None
        self.loaded: dict[str, Instance2] = {}
        self.records: dict[str, np.ndarray] = {}
        self.k = -1  # the sample being computed
        self.recorded = 0  # samples t_0 .. t_{recorded-1} hold every output of every instance
        self.flushed = 0  # samples t_0 .. t_{flushed-1} were handed to the observer

    def hand_over(self, upto: int) -> None:
        """Give the observer samples flushed .. upto-1, then (streaming) reuse the buffer."""
        lo = self.flushed if self.keep else 0
        hi = lo + upto - self.flushed
        if self.observer is not None:
            T = self.scenario.step_size
            block_t = self.times[self.flushed:upto] if self.keep else np.arange(self.flushed, upto, dtype=float) * T
            _call_observer(self.observer.block, block_t, {n: r[lo:hi] for n, r in self.records.items()})
        self.flushed = upto

    def load(self, fmu_paths: dict[str, Path]) -> list:
        """Instantiate and initialise every instance; return the per-step plan: per instance in
        feedthrough order, (instance, its sample buffer, the inputs set right after reading it)."""
        scenario = self.scenario
        for inst in scenario.instances.values():
            path = fmu_paths.get(inst.fmu, inst.file)  # a file: itself, unless the caller gives a copy
            if path is None:
                raise ScenarioError(f"instance '{inst.name}': no built FMU for model '{inst.fmu}'")
            ld = self.loaded[inst.name] = _instance(inst, path, self.logs, self.clock)
            if inst.contract:  # a controller from any tool: contract names, its torques bounded (ported)
                ld = self.loaded[inst.name] = Ported(ld, inst.ports, scenario.torque_limit())
            self.fmus[inst.name] = {"guid": ld.md.guid or "", "version": ld.md.version or "",
                                    "generation_tool": ld.md.generationTool or ""}
        links = _resolve_links(scenario, self.loaded)
        order = _feedthrough_order(self.loaded, links)
        pushes = _input_pushes(order, links)
        for inst in scenario.instances.values():
            ld = self.loaded[inst.name]
            ld.set_parameters(inst.parameters)
            ld.initialize(scenario.stop_time)
            ld.initialized = True
            self.parameters[inst.name] = ld.parameter_values()
            self.records[inst.name] = np.empty((self.rows, len(ld.output_names)))
        if self.observer is not None:
            _call_observer(self.observer.start, scenario,
                           {n: list(ld.output_names) for n, ld in self.loaded.items()}, self.parameters)
        # the clock's call records (``_Clock.call``) made once here, not per step
        return [(self.loaded[name], self.records[name], [(link, (link.target.name, "set")) for link in pushes[name]],
                 (name, "get")) for name in order]

    def loop(self, targets: list) -> bool:
        """Every communication point: read, record, set inputs, step (lists only: no lookups per
        step). True if a signal (orchestration.run.interrupt) stopped it between two steps."""
        n_steps, T, rows = self.scenario.steps, self.scenario.step_size, self.rows
        instances = [(ld, (name, "step")) for name, ld in self.loaded.items()]
        clock, stop = self.clock, interrupt.STATE
        streaming_observer = self.observer is not None
        row = 0
        for k in range(n_steps + 1):
            self.k = clock.sample = k
            for ld, record, pushes, get_call in targets:
                clock.call = get_call
                ld.read_outputs()
                record[row] = ld.out_view
                for link, set_call in pushes:
                    clock.call = set_call
                    link.push()
            self.recorded = k + 1
            row += 1
            if row == rows or (streaming_observer and self.recorded - self.flushed >= self.block_size):
                self.hand_over(self.recorded)
                if not self.keep:
                    row = 0
            if k == n_steps:
                return False
            if stop.requested:  # SIGINT/SIGTERM/SIGHUP: stop here, between two steps
                return True
            t = k * T  # t_k = k T, the same double as np.arange(...) * T
            for ld, step_call in instances:
                clock.call = step_call
                ld.do_step(t, T)
        return False

    def result(self, wall: float, error: str | None, interrupted: bool) -> RunResult:
        completed, T = self.recorded, self.scenario.step_size
        if interrupted and error is None:
            where = f"after t = {(completed - 1) * T:.2f} s (sample {completed - 1})" if completed else "before the first sample"
            error = f"interrupted by {interrupt.signal_name()} {where}"
        common = dict(failed=error is not None, error=error, interrupted=interrupted, logs=self.logs,
                      parameters=self.parameters, fmus=self.fmus)
        if self.keep:  # views into the one array per instance: no second copy of the run
            outputs = {name: {v: self.records[name][:completed, i] for i, v in enumerate(self.loaded[name].output_names)}
                       for name in self.records}
            return RunResult(self.scenario, self.times[:completed], outputs, wall, **common)
        return RunResult(self.scenario, np.empty(0), {}, wall, completed=completed, **common)

    def finish(self, result: RunResult, observer_ok: bool) -> None:
        """Hand the observer the last samples (unless it was the observer that failed) and the result."""
        if self.observer is None:
            return
        try:
            if observer_ok and self.recorded > self.flushed:
                self.hand_over(self.recorded)
        except _ObserverFailed as exc:  # the samples are in the result; say that the observer lost them
            result.failed, result.error = True, (result.error + "; " if result.error else "") + str(exc)
        self.observer.finish(result)


def run(
    scenario: Scenario,
    fmu_paths: dict[str, Path],
    observer: RunObserver | Sequence[RunObserver] | None = None,
    block_size: int = 1000,
    keep_samples: bool = True,
    clock: _Clock | None = None,
) -> RunResult:
    """Run ``scenario`` with the FMUs at ``fmu_paths`` (model identifier -> .fmu file; an instance whose
    ``fmu`` is a file runs that file unless ``fmu_paths`` maps it to a copy).

    A failing FMI call (or any other error once the scenario is accepted, e.g. an FMU that cannot be
    loaded, or an observer that cannot write) ends the run early; the result then has
    ``failed=True``, the error, the FMUs' log messages and every sample recorded up to the failure.
    Instances are always freed. A ``ScenarioError`` (the scenario itself is wrong) is raised.
    ``observer`` (optional, one or a list) is handed the samples every ``block_size`` samples and at
    the end. ``keep_samples=False`` streams: the master then holds one block per instance, not the
    run (memory bounded for any stop time), and the result carries no sample arrays. The FMUs run
    from this user's cache of unpacked FMUs, checked at every load (``orchestration.run.unpacked``).
    ``clock``: where the run keeps its sample and call under way (``orchestration.run.isolated``'s child).
    """
    if block_size < 1:
        raise ScenarioError(f"block_size must be >= 1, got {block_size}")
    if observer is not None and not hasattr(observer, "block"):
        observer = _Fanout(observer)
    session = _Session(scenario, observer, block_size, keep_samples, clock)
    error: str | None = None
    interrupted, observer_ok = False, True
    started = time.perf_counter()
    try:
        interrupt.check()  # a signal before the run: nothing is loaded
        interrupted = session.loop(session.load(fmu_paths))
    except ScenarioError:
        raise  # the scenario itself is wrong: nothing ran
    except interrupt.Interrupted:
        interrupted = True
    except Exception as exc:  # FMI status errors, fmpy's load/instantiate errors, observer errors
        error = _describe_failure(exc, session.k, scenario.step_size, scenario.steps, session.logs)
        observer_ok = not isinstance(exc, _ObserverFailed)
    finally:
        wall = time.perf_counter() - started
        _free(session.loaded)
    result = session.result(wall, error, interrupted)
    session.finish(result, observer_ok)
    return result


def _call_observer(method, *args) -> None:
    try:
        method(*args)
    except Exception as exc:
        raise _ObserverFailed(f"observer failed: {type(exc).__name__}: {exc}") from exc


def _describe_failure(exc: Exception, k: int, step: float, n_steps: int, logs: list[LogRecord]) -> str:
    where = f"at t = {k * step:.2f} s (sample {k})" if 0 <= k <= n_steps else "during set-up"
    what = str(exc) if isinstance(exc, FMICallException) else f"{type(exc).__name__}: {exc}"
    # on one line: pythonfmu puts the reason of a failed instantiation on the line after "[ctor] findClass"
    reasons = "; ".join(f"{r.instance}: {' '.join(r.message.split())}" for r in logs
                        if r.status in ("DISCARD", "ERROR", "FATAL"))
    return f"{what} {where}" + (f" -- {reasons}" if reasons else "")


def _free(loaded: dict[str, Instance2]) -> None:
    for ld in loaded.values():
        if not ld.instantiated:
            continue
        try:
            if ld.initialized:
                ld.fmu.terminate()
        except FMICallException:
            pass
        try:
            ld.fmu.freeInstance()
        except FMICallException:
            pass
        forget_callbacks(ld.callbacks)
        ld.instantiated = False
