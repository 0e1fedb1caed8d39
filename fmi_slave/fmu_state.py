"""The FMU state (fmi2GetFMUstate / fmi2SetFMUstate / serialization) of a ``DescribedSlave``: a
JSON-ready snapshot of every settable variable, the FMI mode, the clock and the model's internal
state, checked field by field before anything of it is applied, and applied all or nothing."""
from __future__ import annotations

import copy
import json
import math
from typing import Any

from pythonfmu import Fmi2Causality, Integer, Real

from fmi_slave.modes import INITIALIZATION, INSTANTIATED, STEPPING, TERMINATED
from fmi_slave.parameters import ParameterSpec


def _is_real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


# the modes a state may bring into an instance in each mode: those from which the FMI calls that follow
# are legal (a fresh instance may take any state but a terminated one; a stepping instance stays stepping,
# or its next doStep would be Discard; a terminated one may be rolled back to stepping)
RESTORABLE = {INSTANTIATED: (INSTANTIATED, INITIALIZATION, STEPPING), INITIALIZATION: (INITIALIZATION,),
              STEPPING: (STEPPING,), TERMINATED: (STEPPING, TERMINATED)}


def _check_state_value(name: str, value: Any, var: Real | Integer, check: ParameterSpec | tuple | None,
                       meta: Any = None) -> None:
    """One variable of a restored state: the type of its variable; a parameter inside its declared
    range (the same check as at initialization); an input or output finite and inside its declared
    [min, max] (what doStep demands of an input, and what an output can be)."""
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
    elif var.causality in (Fmi2Causality.output, Fmi2Causality.input):
        low = -math.inf if meta is None or meta.low is None else meta.low  # the modelDescription's min, max
        high = math.inf if meta is None or meta.high is None else meta.high
        if not (math.isfinite(value) and low <= value <= high):
            raise ValueError(f"{where} = {value!r} must be finite and inside [{low}, {high}]")


def _shape_problem(template: Any, value: Any, path: str) -> str | None:
    """How ``value`` differs in form from ``template`` (this instance's own internal state): a table
    with other keys, or a number, flag or text of another type; None if it does not. Lists and
    absent values (None) are left to the model's ``restore_internal_state``."""
    if isinstance(template, dict):
        if not isinstance(value, dict):
            return f"'{path}' must be a table, got {type(value).__name__}"
        if set(value) != set(template):
            return f"'{path}' must hold exactly the keys {sorted(template)}, got {sorted(map(str, value))}"
        return next((p for k in template if (p := _shape_problem(template[k], value[k], f"{path}.{k}"))), None)
    if isinstance(template, bool) or isinstance(template, str):
        return None if type(value) is type(template) else f"'{path}' = {value!r} must be a {type(template).__name__}"
    if isinstance(template, (int, float)) and not _is_real(value):
        return f"'{path}' = {value!r} must be a number"
    return None


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



class FmuStateMixin:
    """The state calls of ``DescribedSlave`` (which provides ``vars``, ``_mode``, ``_guarded`` and the
    clock fields, and subclasses ``internal_state``/``restore_internal_state``)."""

    def restored_values_problem(self, values: dict[str, Any]) -> str | None:
        """What a model finds wrong with the variable values of a state to restore (each already of
        its type and range), or None; a model whose outputs hold its state bounds them here."""
        return None

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
        if not isinstance(state["mode"], str) or state["mode"] not in RESTORABLE:  # a list is not hashable
            raise ValueError(f"FMU state field 'mode' = {state['mode']!r} is not one of {list(RESTORABLE)}")
        if state["mode"] not in RESTORABLE[self._mode]:
            raise ValueError(f"FMU state field 'mode' = {state['mode']!r} cannot be restored into an instance in "
                             f"mode '{self._mode}' (the FMI calls that follow would be refused); it may restore "
                             f"{list(RESTORABLE[self._mode])}")
        # every parameter in its range, whatever the mode: a state holds no value the FMU would refuse
        for name, value in values.items():
            _check_state_value(name, value, settable[name], self._parameter_checks.get(name), self._meta.get(name))
        problem = self.restored_values_problem(values)
        if problem:
            raise ValueError(f"FMU state field 'values': {problem}")
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
        problem = _shape_problem(self.internal_state(), state["internal"], "internal")
        if problem:
            raise ValueError(f"FMU state field {problem}")

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
