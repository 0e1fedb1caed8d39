"""Shared by the SOTC core tests: random inputs and weights, output lookups, a short sampled loop, and
the 100 s closed-loop runs of ``paper`` and ``paper-pe-only`` (module-scoped fixtures)."""
from __future__ import annotations

import numpy as np

from fmu_controller.sotc import SotcCore
from fmu_plant.dynamics import STEP_SIZE as T
from fmu_plant.dynamics import ArmParameters, rk4_step
from fmu_plant.trajectory import CircleTrajectory
from orchestration.run.metrics import weight_total_variation as metrics_weight_tv
from orchestration.run.scenario import load_scenario


def scenario_params(name: str) -> dict[str, float]:
    """The SOTC parameters a scenario file (orchestration/run/scenarios/<name>.toml) sets."""
    return dict(load_scenario(name).instances["controller"].parameters)


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def out(ctrl: SotcCore, name: str) -> float:
    return ctrl.outputs[ctrl.output_names().index(name)]


def outs(ctrl: SotcCore, *names: str) -> np.ndarray:
    return np.array([out(ctrl, n) for n in names])


def random_inputs(g: np.random.Generator, scale: float = 1.0) -> tuple[list[float], list[float]]:
    y = [0.3 + scale * g.normal(), 1.2 + scale * g.normal(), scale * g.normal(), scale * g.normal()]
    r = [0.3 + 0.3 * g.normal(), 1.2 + 0.3 * g.normal(), *(0.3 * g.normal(size=4))]
    return y, r


def random_weights(g: np.random.Generator, scale: float = 0.5) -> dict[str, float]:
    return {f"W0_{k}": float(w) for k, w in enumerate(scale * g.normal(size=10), start=1)}


def closed_loop_steps(ctrl: SotcCore, n: int, state=(0.5, -0.5, 0.0, 0.0), k0: int = 0):
    """n steps of the sampled loop from step k0; returns the outputs per step and the final plant state."""
    arm, traj = ArmParameters(), CircleTrajectory()
    rec = []
    for k in range(k0, k0 + n):
        t = k * T
        ctrl.evaluate(t, state, traj.sample(t)[:6])
        rec.append(list(ctrl.outputs))
        state = rk4_step(state, ctrl.outputs[0], ctrl.outputs[1], T, 4, arm)
        ctrl.advance(t, T)
    return rec, state


def weight_total_variation(res, t0: float, t1: float) -> float:
    i = res.names.index("W1")
    return metrics_weight_tv(res.t, res.outputs[:, i:i + 10], t0, t1)


def stacked_controller(**params) -> SotcCore:
    """An SOTC after 0.6 s of the sampled loop: its CL stack is full (P = 20 after 0.4 s)."""
    ctrl = SotcCore(**params)
    closed_loop_steps(ctrl, 60)
    assert ctrl.stack.count == ctrl.P
    return ctrl
