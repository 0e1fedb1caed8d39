"""fmi2GetFMUstate/SetFMUstate and their serialization restore the whole state of every FMU.

Each model runs in its loop (controllers in closed loop with the plant and the reference, the plant
alone driven by test signals). After K steps the loop reads the outputs at t_K and pushes them to
the inputs (so a controller has evaluated and cached its torque), then saves every state, steps on
M times (trajectory A). Then:

- in the same instances, after one more read (a different cached evaluation), the states are set
  back: the outputs read at once equal those at t_K, and M steps replay A (B);
- the saved states are serialized and loaded into fresh, only-instantiated instances: same checks (C).

Everything is compared bit for bit, and A must equal an uninterrupted run (taking a state must not
perturb the run).
"""
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from support.fmu_loop import Loop, loop_models, same_bits

from orchestration.fmu_build.build import FMU_SOURCES

K, M = 25, 30  # crosses t = 0.4 s, where the SOTC's probing and CL recording stop


def _row(loop: Loop, row: dict) -> np.ndarray:
    return np.concatenate([row[m] for m in loop.models])


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_state_restore_and_serialization_replay_bitwise(fmu_paths, tmp_path, model, loops):
    models = loop_models(model, fmu_paths)

    reference = Loop(fmu_paths, models, tmp_path, "-ref")
    loops.append(reference)
    reference.initialize()
    uninterrupted = reference.run(K + M + 1)[K:]

    loop = Loop(fmu_paths, models, tmp_path)
    loops.append(loop)
    loop.initialize()
    loop.run(K)
    at_k = _row(loop, loop.sample())
    states = {m: u.fmu.getFMUState() for m, u in loop.units.items()}
    loop.advance()
    a = loop.run(M)
    assert same_bits(np.vstack([at_k, a]), uninterrupted), "taking the FMU state changed the run"

    loop.sample()
    for m, u in loop.units.items():
        u.fmu.setFMUState(states[m])
    loop.k = K
    assert same_bits(loop.read(), at_k), "outputs right after fmi2SetFMUstate differ"
    loop.advance()
    assert same_bits(loop.run(M), a), "set state + replay differs from the first run"

    blobs = {m: u.fmu.serializeFMUState(states[m]) for m, u in loop.units.items()}
    for m, u in loop.units.items():
        u.fmu.freeFMUState(states[m])

    fresh = Loop(fmu_paths, models, tmp_path, "-fresh")  # instantiated only: the state carries the rest
    loops.append(fresh)
    for m, u in fresh.units.items():
        restored = u.fmu.deSerializeFMUstate(blobs[m])
        u.fmu.setFMUState(restored)
        u.fmu.freeFMUState(restored)
    fresh.k = K
    assert same_bits(fresh.read(), at_k), "outputs of a deserialized state differ"
    fresh.advance()
    assert same_bits(fresh.run(M), a), "deserialized state in a fresh instance replays differently"


@pytest.mark.parametrize("model", list(FMU_SOURCES))
def test_foreign_or_corrupt_state_is_refused_and_instance_stays_usable(fmu_paths, tmp_path, model, loops):
    other = next(m for m in FMU_SOURCES if m != model)
    donor = Loop(fmu_paths, [other], tmp_path, "-donor")
    loops.append(donor)
    donor_state = donor.units[other].fmu.getFMUState()
    foreign = donor.units[other].fmu.serializeFMUState(donor_state)
    donor.units[other].fmu.freeFMUState(donor_state)

    loop = Loop(fmu_paths, [model], tmp_path)
    loops.append(loop)
    loop.initialize()
    unit = loop.units[model]
    loop.run(3)
    saved = unit.fmu.getFMUState()
    for blob, what in ((foreign, other), (b"\x00not json", "corrupt")):
        state = unit.fmu.deSerializeFMUstate(blob)
        with pytest.raises(FMICallException):
            unit.fmu.setFMUState(state)
        unit.fmu.freeFMUState(state)
        assert f"not an FMU state of {model}" in unit.logged(), what
    # nothing was applied: the run goes on exactly as from the saved state
    after = loop.run(3)
    unit.fmu.setFMUState(saved)
    unit.fmu.freeFMUState(saved)
    loop.k = 3
    assert same_bits(after, loop.run(3))
