"""FMI 2.0 plumbing shared by every sotc-cosim FMU: variable declaration with units, ranges and
truthful dependencies, a modelDescription that passes ``fmpy validate``, whole-state get/set,
and the error conventions.

pythonfmu 0.7 facts this module is built around (measured, see docs/interop.md):
- its modelDescription lacks UnitDefinitions, units and ModelStructure/InitialUnknowns, and writes
  Real start values with 16 significant digits (pi/2 comes back one ulp off): ``to_xml`` (through
  ``fmu_plant.model_description``) adds the
  former and rewrites starts with ``repr``, which round-trips;
- a Python exception in any callback becomes ``fmi2Fatal``; ``do_step`` returning False becomes
  ``fmi2Discard``. So invalid parameters are refused at ``exitInitializationMode`` by logging the
  reason with status Error and raising (the host sees a non-OK status and the message), and bad
  inputs or step sizes make ``do_step`` log the reason and return False, leaving the state as it was;
- on a Python exception the binary releases its references to the model class, the instance and
  its log queue once, and releases them again when the instance is freed: two releases for one
  reference, which crashes the host process later (seen as a segfault at interpreter exit). Every
  callback here that may raise therefore goes through ``_guarded``, which takes one extra
  reference to each of the three before the exception leaves Python;
- each ``fmi2Instantiate`` re-executes the FMU script in its module's namespace and then releases
  one reference to the module's ``__dict__`` that it never took (it treats the borrowed result of
  ``PyModule_GetDict`` as owned). A script whose module holds no other reference to its dict
  (a class without methods) loses the dict at the first instantiation and the host crashes.
  ``__init_subclass__`` takes one reference each time a model class statement runs: once at
  import, and once in every re-execution, just before the binary's extra release;
- the exported binary finds the model class with the regex ``class X(Fmi2Slave):``, so each FMU
  script imports its base class under the name ``Fmi2Slave``;
- ``fmi2Reset`` makes the binary create a new Python instance of the model class: every variable,
  parameters set before included, is back at its start value (what FMI 2.0 asks of a reset);
- ``fmi2GetFMUstate`` hands the binary the dict ``_get_fmu_state`` returns; serialization calls the
  *class* methods ``_fmu_state_to_bytes``/``_fmu_state_from_bytes`` (JSON), where no instance can
  balance an exception, so those two never raise.
- the binary keeps its interpreter keeper (``PyState``) in a file-static ``shared_ptr`` that both a
  C++ static destructor and its unload hook ``finalizePythonInterpreter`` release. In a binary still
  loaded at ``exit()`` the static destructor runs first and the hook then decrements a counter inside
  the freed block: heap corruption that aborts some processes at exit. ``_settle_binary_teardown``
  leaves both an empty pointer (see its docstring and docs/interop.md, "A non-Python host").

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

import _ctypes
import copy
import ctypes
import json
import math
import os
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, ClassVar, Iterator, Sequence
from xml.etree.ElementTree import Element

from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from fmu_plant.model_description import UNIT_BASES, VariableMeta, complete_model_description
from fmu_plant.parameters import ParameterSpec

PLAN_CACHE = 64  # value-reference lists whose read/write plans are kept per instance
STEP_SIZE = 0.01  # the paper's sampling period T, also each FMU's DefaultExperiment stepSize
# in resources/: parameter start values of a parameterised copy of the FMU (``sotc-cosim export-ssp``
# writes one per SSP component with parameters, so that every engine applies them)
PARAMETER_STARTS = "parameter_starts.json"

# FMI 2.0 co-simulation states (``DescribedSlave._mode``)
INSTANTIATED = "instantiated"
INITIALIZATION = "initialization mode"
STEPPING = "stepping"
TERMINATED = "terminated"


def all_finite(values: Sequence[float]) -> bool:
    """No NaN or infinity among ``values`` (one C-level sum in the common case)."""
    try:
        return math.isfinite(math.fsum(values))
    except OverflowError:  # finite values whose sum overflows
        return all(math.isfinite(v) for v in values)
    except ValueError:  # inf - inf
        return False


def _is_real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _check_state_value(name: str, value: Any, var: Real | Integer, check: ParameterSpec | tuple | None) -> None:
    """One variable of a restored state: the type of its variable; a parameter inside its declared
    range (the same check as at initialization); an output finite (an input may hold anything a
    master could set, NaN included: doStep refuses it)."""
    where = f"FMU state value of '{name}'"
    if isinstance(var, Integer):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{where} = {value!r} must be an integer")
        if isinstance(check, tuple) and not check[0] <= value <= check[1]:
            raise ValueError(f"{where} = {value} is outside its range [{check[0]}, {check[1]}]")
        return
    if not _is_real(value):
        raise ValueError(f"{where} = {value!r} must be a number")
    if isinstance(check, ParameterSpec):
        try:
            check.check(value)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    elif var.causality == Fmi2Causality.output and not math.isfinite(value):
        raise ValueError(f"{where} = {value!r} must be finite")


def _first_nonfinite(tree: Any, path: str) -> str | None:
    """Path of the first non-finite number (or non-JSON value) in a JSON tree, or None."""
    if isinstance(tree, dict):
        for key, value in tree.items():
            bad = _first_nonfinite(value, f"{path}.{key}")
            if bad:
                return bad
    elif isinstance(tree, list):
        for i, value in enumerate(tree):
            bad = _first_nonfinite(value, f"{path}[{i}]")
            if bad:
                return bad
    elif isinstance(tree, float) and not math.isfinite(tree):
        return path
    elif tree is not None and not isinstance(tree, (bool, int, float, str)):
        return path
    return None


_EXIT_CALL_REGISTERED: set[int] = set()  # dlopen handles of binaries whose keeper is released at exit


def _settle_binary_teardown(resources: str | None) -> None:
    """Release the pythonfmu binary's interpreter keeper before ``exit()`` frees it and writes into it.

    The binary's ``finalizePythonInterpreter`` (its unload hook, exported) sets the file-static
    ``shared_ptr<PyState>`` to null. Called by us first, the C++ static destructor and the hook both
    find an empty pointer at exit, whatever the order glibc runs them in. When to call it depends on
    who made the interpreter:

    - the host did (any Python host; ``sys.orig_argv`` is never empty there): the keeper only holds a
      thread that has already ended, so it is released at once. Every ``fmi2Instantiate`` makes a
      new one, so this runs at every instantiation.
    - the binary did (a C host: its worker thread ran ``Py_Initialize``, which leaves
      ``sys.orig_argv`` empty): releasing now would finalize Python under this very call. The call is
      registered with ``__cxa_atexit`` instead, which runs it before the static destructor (entries
      run last-in first-out), and the binary is made ``RTLD_NODELETE`` so the address stays valid.

    Nothing happens when the binary is not loaded (the class instantiated in Python by a builder or
    a test) or not on Linux, where this was measured.
    """
    if sys.platform != "linux" or not resources:
        return
    binaries = sorted((Path(resources).parent / "binaries" / "linux64").glob("*.so"))
    if len(binaries) != 1:
        return
    host_made_python = bool(sys.orig_argv)
    mode = os.RTLD_NOLOAD | (0 if host_made_python else os.RTLD_NODELETE)
    try:
        binary = ctypes.PyDLL(str(binaries[0]), mode=mode)
    except OSError:  # not loaded in this process
        return
    try:
        finalize = binary.finalizePythonInterpreter
        if host_made_python:
            finalize()
        elif binary._handle not in _EXIT_CALL_REGISTERED:
            register = ctypes.CDLL(None)["__cxa_atexit"]
            register.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
            if register(ctypes.cast(finalize, ctypes.c_void_p), None, None) == 0:
                _EXIT_CALL_REGISTERED.add(binary._handle)
    except AttributeError:  # not a pythonfmu binary: nothing to settle
        pass
    finally:
        _ctypes.dlclose(binary._handle)  # only our own reference: unloading stays the host's affair


class DescribedSlave(Fmi2Slave):
    """Base class of every sotc-cosim FMU (pythonfmu ``Fmi2Slave`` with complete metadata).

    Subclasses call ``declare_*`` in ``__init__`` and implement ``initialize`` (validate parameters,
    set the initial outputs), ``step`` (one communication step) and the internal-state pair
    ``internal_state``/``restore_internal_state``.
    """

    author = "sotc-cosim developers"
    license = "MIT"
    version = "0.1.0"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=100.0, step_size=STEP_SIZE)
    # value of each FMI capability flag written to the CoSimulation element
    CAPABILITIES: ClassVar[dict[str, str]] = {
        "canHandleVariableCommunicationStepSize": "true",
        "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true",
        "canBeInstantiatedOnlyOncePerProcess": "false",
    }

    def __init_subclass__(cls, **kwargs: Any):
        super().__init_subclass__(**kwargs)
        module = sys.modules.get(cls.__module__)
        if module is not None:  # balance the binary's release of the script module's dict
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(module.__dict__))

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self._forget_resources_path()
        _settle_binary_teardown(self.resources)
        self._starts, self._starts_problem = self._read_parameter_starts()
        self._meta: dict[str, VariableMeta] = {}
        self._input_ranges: list[tuple[str, float | None, float | None]] = []  # name, low, high
        self._bounded_inputs = False  # some input declares a min or max
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
        self._output_getters: tuple[Callable[[], float], ...] = ()
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

    def declare_output(
        self, name: str, unit: str, description: str, depends_on: Sequence[str] = (),
        getter: Callable[[], float] | None = None,
    ) -> None:
        """An output; ``depends_on`` lists the inputs it depends on directly (empty: none)."""
        if getter is None:
            setattr(self, name, 0.0)
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
        for obj in (self, type(self), self.log_queue):
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))

    # --- variable access ----------------------------------------------------------------------

    def _variable(self, vr: int, kind: type):
        var = self.vars.get(vr)
        if var is None:
            raise ValueError(f"no variable has valueReference {vr}")
        if not isinstance(var, kind):
            raise TypeError(f"'{var.name}' (valueReference {vr}) is a {type(var).__name__}, "
                            f"not a {kind.__name__}")
        return var

    def _set(self, vrs, values, kind: type) -> None:
        """Check every value first, then set them all: a refused call changes nothing."""
        accepted = []
        for vr, value in zip(vrs, values):
            var = self._variable(vr, kind)
            if var.causality == Fmi2Causality.output or var.setter is None:
                raise ValueError(f"'{var.name}' is an output; only inputs and parameters can be set")
            if var.causality == Fmi2Causality.parameter and self._mode in (STEPPING, TERMINATED):
                current = var.getter()
                if value != current:
                    raise ValueError(
                        f"parameter '{var.name}' is fixed once initialization is done; "
                        f"{value!r} refused, it keeps {current!r} (set it before exitInitializationMode, "
                        "or fmi2Reset and initialize again)"
                    )
            accepted.append((var, value))
        for var, value in accepted:
            var.setter(value)
        self._output_problem = None  # outputs computed from the inputs are computed (and checked) again
        if self._mode == INITIALIZATION and any(v.causality == Fmi2Causality.parameter for v, _ in accepted):
            self._preview_stale = True  # the initial outputs follow the parameters

    def _get(self, vrs, kind: type, convert: Callable[[Any], Any]) -> list:
        if self._mode == INITIALIZATION and self._preview_stale:
            self._preview()
        values = []
        for vr in vrs:
            values.append(convert(self._variable(vr, kind).getter()))
        if self._output_problem is not None:  # rare: only after an evaluation gave a non-finite output
            self._refuse_nonfinite(vrs, values)
        return values

    # The per-step calls (a master reads every output and sets the inputs each step with the same
    # value-reference lists) go through plans: the checks of ``_variable`` are done once per list,
    # then a read is one ``output_values`` call and a list of indices, a write one setattr per input.

    def _read_plan(self, vrs) -> tuple[int, ...] | slice | None:
        """Indices into ``output_values()`` for a list of output value references (a slice when it
        is all of them in order); None when the list names anything but Real outputs (those reads
        take the general path)."""
        key = tuple(vrs)
        plan = self._read_plans.get(key, False)
        if plan is False:
            for vr in key:
                self._variable(vr, Real)  # an unknown reference or a non-Real fails here, by name
            index = self._output_index()
            plan = tuple(index[vr] for vr in key) if all(vr in index for vr in key) else None
            if plan == tuple(range(len(index))):
                plan = slice(None)  # every output in declaration order (what a master asks): one copy
            if len(self._read_plans) < PLAN_CACHE:
                self._read_plans[key] = plan
        return plan

    def _output_index(self) -> dict[int, int]:
        if self._outputs_by_vr is None:
            outputs = [v for v in self.vars.values() if v.causality == Fmi2Causality.output and isinstance(v, Real)]
            self._outputs_by_vr = {v.value_reference: i for i, v in enumerate(outputs)}
            self._output_getters = tuple(v.getter for v in outputs)
        return self._outputs_by_vr

    def output_values(self) -> list[float]:
        """Every Real output, in declaration order, at the current state (one pass over their
        getters). Subclasses that hold their outputs together (the controllers) override this."""
        self._output_index()
        return [get() for get in self._output_getters]

    def _write_plan(self, vrs) -> tuple[str, ...] | None:
        """Attribute names for a list of input value references (settable in every state); None
        when the list holds anything else (parameters, outputs, unknown references: general path)."""
        key = tuple(vrs)
        plan = self._write_plans.get(key, False)
        if plan is False:
            found = [self.vars.get(vr) for vr in key]
            plan = (tuple(v.name for v in found)
                    if all(isinstance(v, Real) and v.causality == Fmi2Causality.input for v in found) else None)
            if len(self._write_plans) < PLAN_CACHE:
                self._write_plans[key] = plan
        return plan
    def _refuse_nonfinite(self, vrs, values: list) -> None:
        """Raise (the call then fails; pythonfmu can only say fmi2Fatal here, see docs/interop.md)
        naming the first requested output that is not finite and why, instead of returning it."""
        for vr, value in zip(vrs, values):
            if isinstance(value, float) and not math.isfinite(value):
                raise ValueError(f"output '{self.vars[vr].name}' is {value!r} and is not returned: "
                                 f"{self._output_problem}")

    def set_real(self, vrs, values):
        try:
            plan = self._write_plan(vrs)
            if plan is None:
                self._set(vrs, values, Real)
            else:
                for name, value in zip(plan, values, strict=True):
                    setattr(self, name, value)
        except Exception as exc:
            self._failed("fmi2SetReal", exc)
            raise

    def get_real(self, vrs):
        try:
            plan = self._read_plan(vrs)
            if plan is None:
                return self._get(vrs, Real, float)
            if self._mode == INITIALIZATION and self._preview_stale:
                self._preview()
            values = self.output_values()
            values = values[plan] if type(plan) is slice else [values[i] for i in plan]
            if self._output_problem is not None:  # rare: only after an evaluation gave a non-finite output
                self._refuse_nonfinite(vrs, values)
            return values
        except Exception as exc:
            self._failed("fmi2GetReal", exc)
            raise

    def set_integer(self, vrs, values):
        with self._guarded("fmi2SetInteger"):
            self._set(vrs, values, Integer)

    def get_integer(self, vrs):
        with self._guarded("fmi2GetInteger"):
            return self._get(vrs, Integer, int)

    def set_boolean(self, vrs, values):
        with self._guarded("fmi2SetBoolean"):
            super().set_boolean(vrs, values)

    def get_boolean(self, vrs):
        with self._guarded("fmi2GetBoolean"):
            return super().get_boolean(vrs)

    def set_string(self, vrs, values):
        with self._guarded("fmi2SetString"):
            super().set_string(vrs, values)

    def get_string(self, vrs):
        with self._guarded("fmi2GetString"):
            return super().get_string(vrs)

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
        reason = self.input_problem()
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

    def input_problem(self) -> str | None:
        """Why the current inputs cannot be used (naming the first bad input), or None. The usual
        case costs one pass (``all_finite``, no declared range); otherwise each input is looked at."""
        if not self._bounded_inputs and all_finite([getattr(self, n) for n, _, _ in self._input_ranges]):
            return None
        for name, low, high in self._input_ranges:
            value = getattr(self, name)
            if not math.isfinite(value):
                return f"input '{name}' is {value!r}; the step is refused and the state is kept"
            if (low is not None and value < low) or (high is not None and value > high):
                return (f"input '{name}' = {value!r} is outside its range [{low}, {high}]; "
                        "the step is refused and the state is kept")
        return None

    # --- whole-state snapshot (fmi2GetFMUstate / fmi2SetFMUstate / serialization) -------------

    def _snapshot(self) -> dict[str, Any]:
        values = {v.name: v.getter() for v in self.vars.values() if v.setter is not None}
        return copy.deepcopy({
            "model": type(self).__name__,
            "values": values,
            "mode": self._mode,
            "initialized": self._initialized,
            "preview_stale": self._preview_stale,
            "time": self._time,
            "clock": [self._start_time, self._steps, self._uniform_step],
            "internal": self.internal_state(),
        })

    def _restore(self, state: dict[str, Any]) -> None:
        state = copy.deepcopy(state)
        settable = {v.name: v for v in self.vars.values() if v.setter is not None}
        for name, value in state["values"].items():
            settable[name].setter(value)
        self._mode = state["mode"]
        self._initialized = state["initialized"]
        self._preview_stale = state["preview_stale"]
        self._time = state["time"]
        self._start_time, self._steps, self._uniform_step = state["clock"]
        self._output_problem = None
        self.restore_internal_state(state["internal"])

    def _check_state(self, state: Any) -> None:
        """Refuse (naming the field and what it may be) a state this instance cannot have produced:
        every field is checked against the types and ranges the FMU itself enforces, before anything
        is applied. Cross-field rules (sigma < rho, ...) and the internal state are checked by
        ``restore_internal_state``; ``_set_fmu_state`` undoes everything if that refuses."""
        model = type(self).__name__
        if not isinstance(state, dict) or state.get("model") != model:
            found = state.get("model") if isinstance(state, dict) else type(state).__name__
            raise ValueError(f"not an FMU state of {model} (field 'model' is {found!r}: corrupt or another "
                             "model's state)")
        fields = {"model", "values", "mode", "initialized", "preview_stale", "time", "clock", "internal"}
        if set(state) != fields:
            raise ValueError(f"FMU state of {model} must have exactly the fields {sorted(fields)}, "
                             f"got {sorted(map(str, state))}")
        values = state["values"]
        settable = {v.name: v for v in self.vars.values() if v.setter is not None}
        if not isinstance(values, dict) or set(values) != set(settable):
            found = sorted(values) if isinstance(values, dict) else type(values).__name__
            raise ValueError(f"FMU state field 'values' must hold exactly the variables {sorted(settable)}, got {found}")
        if state["mode"] not in (INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED):
            raise ValueError(f"FMU state field 'mode' = {state['mode']!r} is not one of "
                             f"{[INSTANTIATED, INITIALIZATION, STEPPING, TERMINATED]}")
        # parameters are in force (checked at initialization) once stepping; before, any value a master
        # may set is a legitimate state (exitInitializationMode refuses it)
        in_force = state["mode"] in (STEPPING, TERMINATED)
        for name, value in values.items():
            check = self._parameter_checks.get(name) if in_force else None
            _check_state_value(name, value, settable[name], check)
        for key in ("initialized", "preview_stale"):
            if not isinstance(state[key], bool):
                raise ValueError(f"FMU state field '{key}' = {state[key]!r} must be true or false")
        if state["mode"] in (STEPPING, TERMINATED) and not state["initialized"]:
            raise ValueError(f"FMU state in mode '{state['mode']}' must have 'initialized' = true")
        time = state["time"]
        if not _is_real(time) or not math.isfinite(time):
            raise ValueError(f"FMU state field 'time' = {time!r} must be a finite number")
        clock = state["clock"]
        if not (isinstance(clock, list) and len(clock) == 3):
            raise ValueError(f"FMU state field 'clock' = {clock!r} must be [start time, steps, step size]")
        start, steps, uniform = clock
        if not _is_real(start) or not math.isfinite(start):
            raise ValueError(f"FMU state field 'clock' start time {start!r} must be a finite number")
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
            raise ValueError(f"FMU state field 'clock' step count {steps!r} must be an integer >= 0")
        if uniform is None:
            consistent = steps == 0 and time == start
        elif _is_real(uniform) and math.isnan(uniform):
            consistent = steps > 0
        elif _is_real(uniform) and math.isfinite(uniform) and uniform > 0.0:
            consistent = steps > 0 and time == start + steps * uniform
        else:
            raise ValueError(f"FMU state field 'clock' step size {uniform!r} must be null, NaN or a number > 0")
        if not consistent:
            raise ValueError(f"FMU state fields 'time' = {time!r} and 'clock' = {clock!r} disagree "
                             "(time must be start + steps * step size while the step size is uniform)")
        if not isinstance(state["internal"], dict):
            raise ValueError(f"FMU state field 'internal' must be a table, got {type(state['internal']).__name__}")
        bad = _first_nonfinite(state["internal"], "internal")
        if bad:
            raise ValueError(f"FMU state field '{bad}' is not a finite number")

    def _get_fmu_state(self) -> dict[str, Any]:
        with self._guarded("fmi2GetFMUstate"):
            state = self._snapshot()
            json.dumps(state)  # fail here, naming the call, rather than later in the class-level serializer
            return state

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        with self._guarded("fmi2SetFMUstate (state refused, the instance is unchanged)"):
            self._check_state(state)
            backup = self._snapshot()
            try:
                self._restore(state)
            except Exception as exc:
                self._restore(backup)  # a state that cannot be applied leaves the instance as it was
                raise ValueError(f"FMU state field 'internal' (or a parameter combination) cannot be applied: "
                                 f"{type(exc).__name__}: {exc}") from exc

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        # called on the class: never raise (a state that cannot be written becomes one _set refuses)
        try:
            return json.dumps(state).encode("utf-8")
        except Exception:
            return b"null"

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        # called on the class, where no instance can balance an exception: never raise here,
        # hand a marker to _set_fmu_state, which refuses it
        try:
            return json.loads(state.decode("utf-8"))
        except Exception:
            return {"model": None, "corrupt": True}

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
        for name, value in zip(self.TIME_OUTPUTS, values):
            if not math.isfinite(value):
                return f"output '{name}' would be {value!r} at t = {t!r}"
        for name, value in zip(self.TIME_OUTPUTS, values):
            setattr(self, name, value)
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
