"""FMI 2.0 plumbing shared by every sotc-cosim FMU: variable declaration with units, ranges and
truthful dependencies, a modelDescription that passes ``fmpy validate``, the FMI state machine and
the error conventions. Variable access lives in ``variable_access``, the FMU state in ``fmu_state``,
the workarounds for pythonfmu's binary in ``pythonfmu_fixes``.

pythonfmu 0.7 facts this class is built around (measured, see docs/interop.md):
- its modelDescription lacks UnitDefinitions, units and ModelStructure/InitialUnknowns, and writes
  Real start values with 16 significant digits (pi/2 comes back one ulp off): ``to_xml`` (through
  ``fmi_slave.model_description``) adds the former and rewrites starts with ``repr``, which
  round-trips;
- a Python exception in any callback becomes ``fmi2Fatal``; ``do_step`` returning False becomes
  ``fmi2Discard``. So invalid parameters are refused at ``exitInitializationMode`` by logging the
  reason with status Error and raising (the host sees a non-OK status and the message), and bad
  inputs or step sizes make ``do_step`` log the reason and return False, leaving the state as it was;
- the exported binary finds the model class with the regex ``class X(Fmi2Slave):``, so each FMU
  script imports its base class under the name ``Fmi2Slave``;
- ``fmi2Reset`` makes the binary create a new Python instance of the model class: every variable,
  parameters set before included, is back at its start value (what FMI 2.0 asks of a reset);
- ``fmi2GetFMUstate`` hands the binary the dict ``_get_fmu_state`` returns; serialization calls the
  *class* methods ``_fmu_state_to_bytes``/``_fmu_state_from_bytes`` (JSON), where no instance can
  balance an exception, so those two never raise.

FMI state machine kept by this class (``_mode``): instantiated -> initialization -> stepping ->
terminated. Calls outside their state are refused with a logged Error naming the call and the state
(doStep: Discard; the others: an exception, so fmi2Fatal) and leave the instance as it was:

- fixed parameters can be set before ``exitInitializationMode`` only; setting one to a different value
  later is refused (setting the value it already has is accepted, for masters that re-apply starts);
- outputs cannot be set; an unknown value reference or a variable of another type is refused by name;
- in initialization mode outputs are computed from the current parameters (``initialize`` is run as a
  preview on the first read after a change), so a master that propagates initial values (OSP's
  libcosim does) reads the true initial state, not zeros;
- a non-finite input, or one outside its declared [min, max], makes ``doStep`` log the variable's name
  and return Discard without touching the state.
"""
from __future__ import annotations

import json
import math
import operator
import os
import sys
from contextlib import contextmanager
from typing import Any, Callable, ClassVar, Iterator, Sequence
from xml.etree.ElementTree import Element

from pythonfmu import (
    DefaultExperiment,
    Fmi2Causality,
    Fmi2Slave,
    Fmi2Variability,
    Integer,
    Real,
)
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from fmi_slave import VERSION, compiled_check
from fmi_slave.fmu_state import FmuStateMixin
from fmi_slave.model_description import (
    UNIT_BASES,
    VariableMeta,
    complete_model_description,
)
from fmi_slave.modes import INITIALIZATION, INSTANTIATED, STEPPING, TERMINATED
from fmi_slave.parameters import ParameterSpec
from fmi_slave.pythonfmu_fixes import (
    balance_releases,
    hold_module_dict,
    settle_binary_teardown,
)
from fmi_slave.variable_access import VariableAccessMixin

# in resources/: parameter start values of a parameterised copy of the FMU (``sotc-cosim export-ssp``
# writes one per SSP component with parameters, so that every engine applies them)
PARAMETER_STARTS = "parameter_starts.json"


def all_finite(values: Sequence[float]) -> bool:
    """No NaN or infinity among ``values`` (a list or tuple of floats): one C-level sum in the common case
    (a NaN or an infinity makes it NaN or infinite); only a sum that is not finite, which finite values
    that overflow also give, looks at each value."""
    return math.isfinite(sum(values)) or all(math.isfinite(v) for v in values)



class DescribedSlave(VariableAccessMixin, FmuStateMixin, Fmi2Slave):
    """Base class of every sotc-cosim FMU (pythonfmu ``Fmi2Slave`` with complete metadata).

    Subclasses call ``declare_*`` in ``__init__`` and implement ``initialize`` (validate parameters,
    set the initial outputs), ``step`` (one communication step) and the internal-state pair
    ``internal_state``/``restore_internal_state``.
    """

    author = "sotc-cosim developers"
    license = "MIT"
    version = VERSION
    # the DefaultExperiment's step size: each model sets it (the arm model's T, fmu_plant.dynamics)
    STEP_SIZE: ClassVar[float | None] = None
    STOP_TIME: ClassVar[float] = 100.0  # the paper's runs (section 4)
    # value of each FMI capability flag written to the CoSimulation element
    CAPABILITIES: ClassVar[dict[str, str]] = {
        "canHandleVariableCommunicationStepSize": "true",
        "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true",
        "canBeInstantiatedOnlyOncePerProcess": "false",
    }

    def __init_subclass__(cls, **kwargs: Any):
        super().__init_subclass__(**kwargs)
        hold_module_dict(cls.__module__)
        if cls.STEP_SIZE is not None:
            cls.default_experiment = DefaultExperiment(start_time=0.0, stop_time=cls.STOP_TIME, step_size=cls.STEP_SIZE)

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        for why in compiled_check.FALLBACKS:  # a compiled core that was not loaded, and why
            self.log(why, Fmi2Status.warning)
        self._forget_resources_path()
        settle_binary_teardown(self.resources)
        self._starts, self._starts_problem = self._read_parameter_starts()
        self._meta: dict[str, VariableMeta] = {}
        self._input_ranges: list[tuple[str, float | None, float | None]] = []  # name, low, high
        self._bounded_inputs = False  # some input declares a min or max
        self._input_values: Callable[[Any], Sequence[float]] = lambda slave: ()  # every input, declaration order
        self._mode = INSTANTIATED
        self._initialized = False  # ``initialize`` succeeded with the current parameter values
        self._preview_stale = True  # initialization mode: a parameter changed since the last preview
        self._time = 0.0
        # communication time as t0 + n h while every step has the same size h: the same doubles as a
        # master computing t_k = k T, never a running sum (which drifts by ulps)
        self._start_time = 0.0
        self._steps = 0
        self._uniform_step: float | None = None  # h while uniform, nan once a step size changed
        # value-reference lists seen by get_real/set_real -> their plans (``_read_plan``, ``_write_plan``)
        self._read_plans: dict[tuple[int, ...], tuple[int, ...] | slice | None] = {}
        self._write_plans: dict[tuple[int, ...], tuple[str, ...] | None] = {}
        self._outputs_by_vr: dict[int, int] | None = None  # output value reference -> index
        self._read_outputs: Callable[[], list[float]] = list  # every output in order (``_output_index`` sets it)
        self._attribute_outputs: set[str] = set()  # outputs held in attributes (declared without a getter)
        # how each parameter is checked (a ParameterSpec, or (low, high) of an Integer): also applied to
        # the values of a restored FMU state
        self._parameter_checks: dict[str, ParameterSpec | tuple[int, int]] = {}
        # why an output computed at the last evaluation is not finite, or None: ``_get`` then refuses
        # to return a non-finite value (set where outputs are computed, so a get costs one check)
        self._output_problem: str | None = None

    def _forget_resources_path(self) -> None:
        """pythonfmu's binary inserts ``resources/`` at ``sys.path[0]`` at every fmi2Instantiate and
        never removes it. Every module this FMU needs is imported by now, under names unique to its
        build, so the entry is taken out again: the host's ``sys.path`` stays as it was."""
        if self.resources and sys.path and sys.path[0] == self.resources:
            del sys.path[0]

    def _read_parameter_starts(self) -> tuple[dict[str, Any], str | None]:
        """Start values from ``resources/parameter_starts.json`` (absent: the declared defaults)."""
        if not self.resources:
            return {}, None
        try:
            with open(os.path.join(self.resources, PARAMETER_STARTS), encoding="utf-8") as f:
                starts = json.load(f)
        except FileNotFoundError:
            return {}, None
        except (OSError, ValueError) as exc:
            return {}, f"{PARAMETER_STARTS} cannot be read: {exc}"
        if not isinstance(starts, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                   for v in starts.values()):
            return {}, f"{PARAMETER_STARTS} must map parameter names to numbers"
        return starts, None

    # --- declaration -------------------------------------------------------------------------

    def declare_parameter(self, spec: ParameterSpec) -> None:
        """A fixed parameter whose value is checked against ``spec`` at initialization (an FMI
        Integer when ``spec.integer``, else a Real)."""
        if spec.integer:
            self.declare_integer_parameter(spec.name, int(spec.default), int(spec.low), int(spec.high), spec.description)
            return
        setattr(self, spec.name, float(self._starts.get(spec.name, spec.default)))
        self._parameter_checks[spec.name] = spec
        self._register(
            Real(spec.name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                 initial=Fmi2Initial.exact, description=f"{spec.description}; valid range {spec.range_text()}"),
            VariableMeta(spec.unit, None if math.isinf(spec.low) else spec.low,
                  None if math.isinf(spec.high) else spec.high, None),
        )

    def declare_integer_parameter(self, name: str, default: int, low: int, high: int, description: str) -> None:
        setattr(self, name, int(self._starts.get(name, default)))
        self._parameter_checks[name] = (low, high)
        self._register(
            Integer(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                    initial=Fmi2Initial.exact, description=f"{description}; valid range [{low}, {high}]"),
            VariableMeta(None, low, high, None),
        )

    def declare_input(
        self, name: str, unit: str, description: str, start: float = 0.0,
        low: float | None = None, high: float | None = None,
    ) -> None:
        """A continuous input; ``low``/``high`` (optional) become min/max, and doStep refuses values outside."""
        setattr(self, name, start)
        self._register(
            Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                 description=description),
            VariableMeta(unit, low, high, None),
        )
        self._input_ranges.append((name, low, high))
        self._bounded_inputs = self._bounded_inputs or low is not None or high is not None
        names = [n for n, _, _ in self._input_ranges]  # one C call per read (attrgetter of one name: no tuple)
        self._input_values = operator.attrgetter(*names) if len(names) > 1 else lambda slave: (getattr(slave, name),)

    def declare_output(
        self, name: str, unit: str, description: str, depends_on: Sequence[str] = (),
        getter: Callable[[], float] | None = None,
    ) -> None:
        """An output; ``depends_on`` lists the inputs it depends on directly (empty: none)."""
        if getter is None:
            setattr(self, name, 0.0)
            self._attribute_outputs.add(name)
        self._register(
            Real(name, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                 description=description, getter=getter),
            VariableMeta(unit, None, None, tuple(depends_on)),
        )

    def _register(self, var: Real | Integer, meta: VariableMeta) -> None:
        if meta.unit is not None and meta.unit not in UNIT_BASES:
            raise ValueError(f"unit {meta.unit!r} of {var.name} is missing from UNIT_BASES")
        self.register_variable(var)
        self._meta[var.name] = meta

    def parameter_values(self, specs: Sequence[ParameterSpec]) -> dict[str, float]:
        return {s.name: getattr(self, s.name) for s in specs}

    # --- modelDescription --------------------------------------------------------------------

    def to_xml(self, model_options: dict[str, str] = dict()) -> Element:  # noqa: B006 (pythonfmu's signature)
        return complete_model_description(super().to_xml(model_options), self.vars, self._meta, self.CAPABILITIES)

    # --- exceptions that leave Python -----------------------------------------------------------

    @contextmanager
    def _guarded(self, call: str) -> Iterator[None]:
        """Log any exception of ``call`` with status Error and balance pythonfmu's extra releases."""
        try:
            yield
        except Exception as exc:
            self._failed(call, exc)
            raise

    def _failed(self, call: str, exc: Exception) -> None:
        """``_guarded``'s work, for the per-step calls that use a plain try (no context manager
        per call): log ``exc`` with status Error and take the references the binary will release."""
        self.log(f"{self.instance_name}: {call} failed: {exc}", Fmi2Status.error)
        balance_releases(self, type(self), self.log_queue)

    # --- lifecycle ----------------------------------------------------------------------------

    def _require_mode(self, call: str, *allowed: str) -> None:
        if self._mode not in allowed:
            raise RuntimeError(f"{call} is not allowed in state '{self._mode}' (allowed in: {', '.join(allowed)})")

    def setup_experiment(self, start_time: float, stop_time: float | None = None, tolerance: float | None = None):
        with self._guarded("fmi2SetupExperiment"):
            self._require_mode("fmi2SetupExperiment", INSTANTIATED)
            if not math.isfinite(start_time):
                raise ValueError(f"fmi2SetupExperiment: start time {start_time!r} is not finite")
            self._time = self._start_time = float(start_time)
            self._steps, self._uniform_step = 0, None

    def enter_initialization_mode(self) -> None:
        with self._guarded("fmi2EnterInitializationMode"):
            self._require_mode("fmi2EnterInitializationMode", INSTANTIATED)
        self._mode = INITIALIZATION
        self._preview_stale = True

    def exit_initialization_mode(self) -> None:
        with self._guarded("fmi2ExitInitializationMode (initialization refused)"):
            self._require_mode("fmi2ExitInitializationMode", INITIALIZATION)
            self._check_parameter_starts()
            self._initialized = False
            self.initialize()  # raises naming the parameter; the instance stays in initialization mode
        self._initialized = True
        self._preview_stale = False
        self._mode = STEPPING

    def _check_parameter_starts(self) -> None:
        parameters = {v.name for v in self.vars.values() if v.causality == Fmi2Causality.parameter}
        unknown = sorted(set(self._starts) - parameters)
        if self._starts_problem or unknown:
            raise ValueError(self._starts_problem or f"{PARAMETER_STARTS} names {unknown}, which are not parameters")

    def _preview(self) -> None:
        """Initialization mode: compute the initial outputs from the parameters set so far."""
        self._preview_stale = False
        try:
            self.initialize()
            self._initialized = True
        except Exception as exc:
            self._initialized = False
            self.log(f"{self.instance_name}: outputs are not defined in initialization mode yet: {exc}",
                     Fmi2Status.warning)

    def terminate(self) -> None:
        self._mode = TERMINATED

    def do_step(self, current_time: float, step_size: float) -> bool:
        try:
            if current_time == self._time and step_size == self._uniform_step and self._mode == STEPPING:
                # the usual step: from where the FMU is, the size of every step before it (accepted
                # then as finite and > 0; nan, once a size changed, equals nothing): nothing to recheck
                return self._advance(current_time, step_size)
            return self._do_step(current_time, step_size)
        except Exception as exc:  # a bug must not take the host down: refuse the step instead
            return self.discard(f"doStep failed: {type(exc).__name__}: {exc}")

    def _do_step(self, current_time: float, step_size: float) -> bool:
        if self._mode != STEPPING:
            when = "before exitInitializationMode" if self._mode != TERMINATED else "after fmi2Terminate"
            return self.discard(f"doStep called {when} (state '{self._mode}')")
        if not (math.isfinite(step_size) and step_size > 0.0):
            return self.discard(f"communication step size must be finite and > 0, got {step_size!r}")
        if not math.isclose(current_time, self._time, rel_tol=1e-12, abs_tol=1e-9):
            return self.discard(
                f"doStep starts at t = {current_time!r} but the FMU is at t = {self._time!r}; "
                "rewind with fmi2SetFMUstate instead of jumping in time"
            )
        return self._advance(current_time, step_size)

    def _advance(self, current_time: float, step_size: float) -> bool:
        """A step whose time and size were accepted: the inputs checked, ``step``, the clock moved."""
        reason = None if self.inputs_checked() else self.input_problem()
        if reason:
            return self.discard(reason)
        reached = self.next_time(current_time, step_size)
        ok = self.step(current_time, step_size)
        if ok:
            if self._uniform_step is None or self._uniform_step == step_size:
                self._uniform_step = step_size
                self._steps += 1
            else:
                self._uniform_step = math.nan
            self._time = reached
        return ok

    def next_time(self, current_time: float, step_size: float) -> float:
        """The communication time a successful ``doStep(current_time, step_size)`` reaches: t0 + n h
        while every step has had the same size h, else current_time + step_size."""
        if self._uniform_step is None or self._uniform_step == step_size:
            return self._start_time + (self._steps + 1) * step_size
        return current_time + step_size

    def discard(self, reason: str) -> bool:
        """Log why a step is refused; returning False makes pythonfmu answer fmi2Discard."""
        self.log(f"{self.instance_name}: {reason}", Fmi2Status.error)
        return False

    def inputs_checked(self) -> bool:
        """True when ``input_problem`` found the current inputs good since they last changed (a model
        that checks them when it reads them says so; doStep then does not check them again), or when
        there are no inputs."""
        return not self._input_ranges

    def input_problem(self, values: Sequence[float] | None = None) -> str | None:
        """Why the current inputs cannot be used (naming the first bad input), or None. The usual
        case costs one pass (``all_finite``, no declared range); otherwise each input is looked at.
        ``values``: every input in declaration order, when the caller has read them already."""
        if values is None:
            values = self._input_values(self)
        if not self._bounded_inputs and all_finite(values):
            return None
        for name, low, high in self._input_ranges:
            value = getattr(self, name)
            if not math.isfinite(value):
                return f"input '{name}' is {value!r}; the step is refused and the state is kept"
            if (low is not None and value < low) or (high is not None and value > high):
                return (f"input '{name}' = {value!r} is outside its range [{low}, {high}]; "
                        "the step is refused and the state is kept")
        return None


    # --- to implement ---------------------------------------------------------------------------

    def initialize(self) -> None:
        """Validate parameters (raise ParameterError naming the parameter) and set initial outputs."""

    def step(self, current_time: float, step_size: float) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def internal_state(self) -> dict[str, Any]:
        """State not held in registered variables, JSON-serialisable."""
        return {}

    def restore_internal_state(self, state: dict[str, Any]) -> None:
        """Inverse of ``internal_state``."""


class TimeFunctionSlave(DescribedSlave):
    """An FMU whose outputs are a function of time and parameters alone (no inputs): subclasses list
    them in ``TIME_OUTPUTS`` and give ``outputs_at(t)``. Every value is checked where it is computed:
    a non-finite one refuses initialization (naming the output) or the step (Discard, state kept)."""

    TIME_OUTPUTS: ClassVar[tuple[str, ...]] = ()

    def outputs_at(self, t: float) -> Sequence[float]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _publish(self, t: float) -> str | None:
        """Set the outputs to their values at t, or (leaving them) say which one is not finite."""
        try:
            values = self.outputs_at(t)
        except (ValueError, OverflowError) as exc:
            return f"the outputs at t = {t!r} cannot be computed: {exc}"
        if not all_finite(values):
            name, value = next((n, v) for n, v in zip(self.TIME_OUTPUTS, values) if not math.isfinite(v))
            return f"output '{name}' would be {value!r} at t = {t!r}"
        self.__dict__.update(zip(self.TIME_OUTPUTS, values))  # plain attributes (``declare_output``)
        return None

    def publish_initial(self, parameters: Sequence[str]) -> None:
        """At initialization: the outputs at the start time, or a refusal naming ``parameters``."""
        problem = self._publish(self._time)
        if problem:
            values = ", ".join(f"'{n}' = {getattr(self, n)!r}" for n in parameters)
            raise ValueError(f"{problem}: parameters {values} give no finite output")

    def step(self, current_time: float, step_size: float) -> bool:
        problem = self._publish(self.next_time(current_time, step_size))
        return self.discard(f"{problem}; the step is refused and the state is kept") if problem else True
