"""A controller FMU from any tool in the master (docs/benchmark.md): its variables under the contract's names,
and the actuator between it and the arm.

The scenario's port map names the FMU's own variable for each contract name it uses (``ports``; without one,
its variables of the contract's own names, ``port_map``). ``Ported`` wraps the master's instance of the FMU
(``fmi2_instance.Instance2`` for FMI 2.0, ``fmi3_instance.Instance3`` for FMI 3.0, loaded through the same path and
their model description parsed once) and presents it to the master as one of ours:

* its mapped inputs are the contract's names (``phi1`` ... ``ddphi2_d``), so the scenario's ``[[connect]]``
  pairs match them by name; its inputs no contract name feeds keep their start values;
* its outputs are every output of the FMU under the FMU's own names (an FMU whose own name is one the
  actuator writes below gets ``_fmu`` appended), then ``tau1 tau2``: the torques the FMU wrote, projected
  radially onto ||tau|| <= rho (``saturation.saturate_norm``) before the arm gets them, and ``torque_cut``:
  1 at a sample where that projection cut them by more than rounding (``CUT_MARGIN``), else 0 (the summary
  counts them: ``torque_cuts``).

Our own controllers bound themselves and run without this wrapper (no cost per step for them).
"""
from __future__ import annotations

import ctypes
import re

import numpy as np

from fmi3_slave.arrays import element_names
from fmu_controller.ports import CONTRACT_NAMES, TORQUE_PORTS
from fmu_controller.saturation import saturate_norm
from orchestration.run.fmi3_direct import element_count
from orchestration.run.metrics import TORQUE_CUT
from orchestration.run.scenario import ScenarioError

ELEMENT = re.compile(r"([A-Za-z_][A-Za-z0-9_.]*)\[([1-9][0-9]*)\]")  # an FMI 3.0 array's element, from 1
OWN_SUFFIX = "_fmu"  # appended to an output of the FMU named like one the actuator writes
# relative: a torque no further than this outside the bound is a controller's own radial scaling onto it, off by
# rounding (an ulp is 2e-16 of it): moved into the disc like any other, but not counted as cut. The count is
# printed in every summary, and the FMU's libm decides in its last bit whether such a torque lands outside
CUT_MARGIN = 1e-9


def cut_flag(moved, norm, cut_above):
    """``torque_cut`` of a sample: 1.0 where the actuator moved the FMU's torques (``saturate_norm``'s flag) from a
    norm beyond ``cut_above`` (the bound and ``CUT_MARGIN``), else 0.0. The one rule for a sample (bool, float) and
    for a run's columns at once (numpy arrays: ``foreign_loop`` flags a whole run after it ran)."""
    return 1.0 * (moved & (norm > cut_above))


def element(variables: dict, name: str):
    """The variable ``name`` names: a variable of that name (FMI 2.0 tools name scalars ``u[1]`` too), or else
    ``array[i]`` (from 1) of an FMI 3.0 array of fixed size; None: no such variable or element."""
    m = ELEMENT.fullmatch(name)
    if name in variables or m is None:
        return variables.get(name)
    array, index = variables.get(m[1]), int(m[2])
    sizes = [int(d.start) for d in array.dimensions if d.start is not None] if array is not None else []
    return array if len(sizes) == 1 == len(array.dimensions) and 1 <= index <= sizes[0] else None


def own_name(variables: dict, key: str) -> str | None:
    """The FMU's variable of the contract name ``key``: itself, or the element of an array of its stem (FMI 3.0
    ``tau[1]`` for ``tau1``); None if it has neither."""
    stem, index = key[:-1], key[-1]
    for name in (key, f"{stem}[{index}]" if index.isdigit() else None):
        if name is not None and element(variables, name) is not None:
            return name
    return None


def port_map(variables: dict, ports: dict[str, str] | None) -> dict[str, str]:
    """``ports`` (contract name -> the FMU's variable), or without one the FMU's variables of the contract's
    names (the torques always, found or not, so that a check names them)."""
    if ports:
        return dict(ports)
    own = {k: own_name(variables, k) for k in CONTRACT_NAMES}
    return {k: n or k for k, n in own.items() if n or k in TORQUE_PORTS}


def _recorded(name: str) -> str:
    """The name the master records the FMU's output ``name`` under: its own, unless the actuator writes one so."""
    return name + OWN_SUFFIX if name in (*TORQUE_PORTS, TORQUE_CUT) else name


def written(variables: dict, ports: dict[str, str] | None) -> list[str]:
    """The recorded names of the torques the FMU itself wrote (before the actuator), ``tau1`` then ``tau2``."""
    names = port_map(variables, ports)
    return [_recorded(_scalar(variables, names[key])) for key in TORQUE_PORTS]


def _scalar(variables: dict, name: str) -> str:
    """The master's name of the FMU variable a port map names: FMI 3.0 ``u[2]`` is the instance's ``u2``."""
    m = ELEMENT.fullmatch(name)
    if name in variables or m is None:
        return name
    return element_names(m[1], element_count(variables[m[1]]))[int(m[2]) - 1]


class Ported:
    """The master's instance ``inner`` of a controller FMU from any tool, under the contract's names, with the
    actuator that bounds its torques to ``bound`` (the interface of ``fmi2_instance.Instance2``)."""

    def __init__(self, inner, ports: dict[str, str], bound: float):
        variables = {v.name: v for v in inner.md.modelVariables}
        scalars = {key: _scalar(variables, name) for key, name in port_map(variables, ports).items()
                   if element(variables, name) is not None}
        missing = [k for k in TORQUE_PORTS if scalars.get(k) not in inner.output_names]
        wrong = [k for k in scalars if k not in TORQUE_PORTS and scalars[k] not in inner.inputs]
        if missing or wrong:
            raise ScenarioError(f"instance '{inner.name}': ports {', '.join(missing + wrong)}: not the FMU's "
                                "real output (torques) or input (sotc-cosim check-controller names why)")
        self.inner, self.name, self.md, self.fmu, self.bound = inner, inner.name, inner.md, inner.fmu, bound
        self.cut_above = bound * (1.0 + CUT_MARGIN)
        self.callbacks, self.feedthrough, self.raw_set = inner.callbacks, inner.feedthrough, inner.raw_set
        self.instantiated, self.initialized = True, False
        self.initialize, self.do_step = inner.initialize, inner.do_step
        self.parameter_values, self.set_parameters = inner.parameter_values, inner.set_parameters
        self.output_names = [_recorded(n) for n in inner.output_names] + [*TORQUE_PORTS, TORQUE_CUT]
        self.inputs = {k for k in scalars if k not in TORQUE_PORTS}
        self.vars = {k: inner.vars[scalars[k]] for k in self.inputs}
        self.torque_index = [inner.output_names.index(scalars[k]) for k in TORQUE_PORTS]
        self.n_own = len(inner.output_names)
        self.out_buf = (ctypes.c_double * len(self.output_names))()
        self.out_view = np.ctypeslib.as_array(self.out_buf)

    def read_outputs(self) -> None:
        """The FMU's outputs, then the torques the arm gets and whether the actuator cut them."""
        self.inner.read_outputs()
        out, n = self.out_view, self.n_own
        out[:n] = self.inner.out_view
        i1, i2 = self.torque_index
        t1, t2, norm, moved = saturate_norm(float(out[i1]), float(out[i2]), self.bound)
        out[n], out[n + 1], out[n + 2] = t1, t2, cut_flag(moved, norm, self.cut_above)
