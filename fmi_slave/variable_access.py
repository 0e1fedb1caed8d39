"""Typed get/set of an FMU's variables for ``DescribedSlave``: every value checked before any is
set, outputs refused as targets, a non-finite output refused by name, and per-list plans so that a
master's per-step reads and writes cost one pass."""
from __future__ import annotations

import math
from operator import attrgetter
from typing import Any, Callable

from pythonfmu import Fmi2Causality, Integer, Real

from fmi_slave.modes import INITIALIZATION, STEPPING, TERMINATED

PLAN_CACHE = 64  # value-reference lists whose read/write plans are kept per instance


class VariableAccessMixin:
    """The get/set calls of ``DescribedSlave`` (which provides ``vars``, ``_mode``, ``_guarded``,
    ``_failed``, ``_preview`` and the plan caches)."""

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
            names = [v.name for v in outputs]
            if len(names) > 1 and set(names) <= self._attribute_outputs:
                read = attrgetter(*names)  # one C call reads them all
                self._read_outputs = lambda: list(read(self))
            else:
                getters = tuple(v.getter for v in outputs)
                self._read_outputs = lambda: [get() for get in getters]
        return self._outputs_by_vr

    def output_values(self) -> list[float]:
        """Every Real output, in declaration order, at the current state (one ``attrgetter`` call when
        they are attributes, else one pass over their getters). Subclasses that hold their outputs
        together (the controllers) override this."""
        self._output_index()
        return self._read_outputs()

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
                self.__dict__.update(zip(plan, values, strict=True))  # inputs are plain attributes (``declare_input``)
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
            values = self.output_values()  # a list the binary only reads: every output in order is returned as it is
            if type(plan) is not slice:
                values = [values[i] for i in plan]
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
