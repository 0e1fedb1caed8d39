"""Hostile FMU states: a state restored through fmi2DeSerializeFMUstate/fmi2SetFMUstate is checked
against the same ranges as parameters and inputs, its outputs must be finite, in their declared
range and (the arm's state lives in its outputs) in the arm's range, and its mode must be one from
which the FMI calls that follow are legal. Each of the 32 states below was accepted before
and is now refused; the instance then runs on exactly as from its own saved state."""
from __future__ import annotations

import json

import pytest
from fmpy.fmi1 import FMICallException
from support.fmu_loop import Loop, same_bits

from orchestration.fmu_build.build import FMU_SOURCES

STEPS = 5


def _values(**changes):
    return lambda s: s["values"].update(changes)


def _core(key, value):
    return lambda s: s["internal"]["core"].__setitem__(key, value)


def _first_weight(value):
    return lambda s: s["internal"]["core"]["W"].__setitem__(0, value)


# (model, what, change of the JSON state, taken while stepping or in initialization mode); every one
# was accepted before: 16 modes, 3 outputs, 4 internal values, 4 inputs, 5 parameters of a state
# taken in initialization mode
HOSTILE = [
    *((m, f"mode {mode}", lambda s, mode=mode: s.update(mode=mode), "stepping") for m in FMU_SOURCES
      for mode in ("terminated", "instantiated")),
    ("ArmPlant", "output phi1 1e308", _values(phi1=1e308), "stepping"),
    ("ArmPlant", "output dphi2 1e308", _values(dphi2=1e308), "stepping"),
    ("ArmPlant", "output ee_x 1e308", _values(ee_x=1e308), "stepping"),
    ("SotcController", "W 1e300", _first_weight(1e300), "stepping"),
    ("SotcController", "W -1e300", _first_weight(-1e300), "stepping"),
    ("SotcController", "next_record_t -1e300", _core("next_record_t", -1e300), "stepping"),
    ("SotcController", "next_record_t 1e300", _core("next_record_t", 1e300), "stepping"),
    ("SotcController", "input phi1 nan", _values(phi1=float("nan")), "stepping"),
    ("ArmPlant", "input tau1 inf", _values(tau1=float("inf")), "stepping"),
    ("CtController", "input phi1_d nan", _values(phi1_d=float("nan")), "stepping"),
    ("LqrController", "input dphi1 -inf", _values(dphi1=float("-inf")), "stepping"),
    ("SotcController", "rho 1e30", _values(rho=1e30), "init"),
    ("SotcController", "rho 1e300", _values(rho=1e300), "init"),
    ("SotcController", "W0_1 1e300", _values(W0_1=1e300), "init"),
    ("OtcController", "rho 1e30", _values(rho=1e30), "init"),
    ("ArmPlant", "phi1_0 1e30", _values(phi1_0=1e30), "init"),
]


def test_the_hostile_states_are_32():
    assert len(HOSTILE) == 32


@pytest.mark.parametrize("model, what, change, taken", HOSTILE, ids=[f"{m}-{w}" for m, w, _, _ in HOSTILE])
def test_a_hostile_state_is_refused_and_the_instance_runs_on(fmu_paths, tmp_path, loops, model, what, change, taken):
    loop = Loop(fmu_paths, [model], tmp_path)
    loops.append(loop)
    unit = loop.units[model]
    if taken == "init":
        unit.fmu.setupExperiment(startTime=0.0)
        unit.fmu.enterInitializationMode()
    else:
        loop.initialize()
        loop.run(STEPS)
    saved = unit.fmu.getFMUState()
    state = json.loads(bytes(unit.fmu.serializeFMUState(saved)))
    change(state)
    hostile = unit.fmu.deSerializeFMUstate(json.dumps(state).encode())
    with pytest.raises(FMICallException):
        unit.fmu.setFMUState(hostile)
    unit.fmu.freeFMUState(hostile)
    assert "state refused, the instance is unchanged" in unit.logged(), what
    if taken == "init":  # still in initialization mode, with its own values: it goes on to step
        unit.fmu.freeFMUState(saved)
        unit.fmu.exitInitializationMode()
        assert loop.run(3).shape[0] == 3
        return
    after = loop.run(3)  # nothing was applied: the run goes on as from the saved state
    unit.fmu.setFMUState(saved)
    unit.fmu.freeFMUState(saved)
    loop.k = STEPS
    assert same_bits(after, loop.run(3))


def test_a_stepping_state_still_restores_into_a_fresh_instance(fmu_paths, tmp_path, loops):
    """The legal cross-mode restore (warm start: a saved stepping state into an instantiated instance)."""
    source = Loop(fmu_paths, ["SotcController"], tmp_path, "-a")
    loops.append(source)
    source.initialize()
    source.run(STEPS)
    unit = source.units["SotcController"]
    saved = unit.fmu.getFMUState()
    blob = unit.fmu.serializeFMUState(saved)
    unit.fmu.freeFMUState(saved)
    fresh = Loop(fmu_paths, ["SotcController"], tmp_path, "-b")
    loops.append(fresh)
    state = fresh.units["SotcController"].fmu.deSerializeFMUstate(blob)
    fresh.units["SotcController"].fmu.setFMUState(state)
    fresh.units["SotcController"].fmu.freeFMUState(state)
    fresh.k = source.k
    assert same_bits(source.run(3), fresh.run(3))
