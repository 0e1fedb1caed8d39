"""How good is a critic W as a value function, and how good is the policy (28) it induces?

Two measures, both through the SOTC core itself (no second copy of its formulas):

* ``hjb_residual_ratio``: the residual of (29), e1 = W^T eta + z^T Theta z + Omega(mu_hat(W)), which
  is the HJB residual (22) of J_hat = W^T zeta under its own minimising policy, on a grid of error
  states (e, e_dot) at frozen configurations phi2 (the core's ``e1`` output, with PE and CL off);
  reported as RMS over the grid relative to W = 0 (whose residual is z^T Theta z);
* ``cost_to_go``: the realised cost (12), integral of z^T Theta z + Omega(mu_hat) (the core's
  ``cost_rate``), from a fixed set of initial states around the path over a horizon, with W frozen
  (alpha1 = alpha2 = 1e-9, no CL, no PE): the cost of the policy W induces.
"""
from __future__ import annotations

import itertools

import numpy as np

from fmu_controller.sotc import SotcCore
from fmu_plant.trajectory import CircleTrajectory
from orchestration.run.metrics import _trapezoid
from orchestration.study.pure_loop import simulate

PHI2_GRID = (0.6, 1.4, 2.2)  # rad, across the circle's range of phi2_d [0.59, 2.19]
ERROR_GRID = np.linspace(-0.2, 0.2, 5)  # e_i [rad] and e_dot_i [rad/s]
N_STATES, SPAN, HORIZON, SEED = 16, 0.3, 20.0, 0
FROZEN = {"alpha1": 1e-9, "alpha2": 1e-9, "cl_enabled": 0.0, "pe_amplitude": 0.0}


def _core(W: np.ndarray, **params: float) -> SotcCore:
    return SotcCore(**{f"W0_{k + 1}": float(w) for k, w in enumerate(W)}, **FROZEN, **params)


def hjb_residuals(W: np.ndarray, **params: float) -> np.ndarray:
    """e1 of (29) at every grid point (e1, e2, de1, de2) x phi2, with the reference at rest."""
    core = _core(W, **params)
    out = []
    k = core.output_names().index("e1")
    for phi2 in PHI2_GRID:
        for e1, e2, de1, de2 in itertools.product(ERROR_GRID, repeat=4):
            core.evaluate(1.0, (e1, phi2, de1, de2), (0.0, phi2 - e2, 0.0, 0.0, 0.0, 0.0))
            out.append(core.outputs[k])
    return np.array(out)


def hjb_residual_ratio(W: np.ndarray, **params: float) -> float:
    """RMS of the HJB residual of W over the grid, relative to W = 0's."""
    rms = lambda w: float(np.sqrt(np.mean(hjb_residuals(w, **params) ** 2)))  # noqa: E731
    return rms(np.asarray(W, dtype=float)) / rms(np.zeros(10))


def initial_states() -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """N_STATES (phi(0), dphi(0)): the path's start plus uniform errors in [-SPAN, SPAN] (seeded)."""
    ref = CircleTrajectory().sample(0.0)
    g = np.random.default_rng(SEED)
    out = []
    for d in g.uniform(-SPAN, SPAN, (N_STATES, 4)):
        out.append(((ref[0] + d[0], ref[1] + d[1]), (ref[2] + d[2], ref[3] + d[3])))
    return out


def cost_to_go(W: np.ndarray, horizon: float = HORIZON, **params: float) -> np.ndarray:
    """Realised cost (12) over ``horizon`` from each of ``initial_states()`` under the frozen policy of W."""
    costs = []
    for phi0, dphi0 in initial_states():
        res = simulate(_core(np.asarray(W, dtype=float), **params), stop_time=horizon, phi0=phi0, dphi0=dphi0)
        costs.append(float(_trapezoid(res.out("cost_rate"), res.t)))
    return np.array(costs)


VALUE_HEADER = ["W", "HJB residual RMS / W = 0's", "cost-to-go, sum over the states", "relative to LQR",
                "states where below LQR"]


def value_rows(learned: np.ndarray, horizon: float = HORIZON) -> list[tuple[str, float, float, float, int, int]]:
    """(label, HJB residual ratio, summed cost-to-go, relative to LQR's, states below LQR, states) for the
    learned W, W = 0, the paper's W and the LQR weights of the linearised (6) at phi2 = 1.39 rad."""
    from orchestration.study.sotc_study import PAPER_W, lqr_weights

    candidates = [("learned W", np.asarray(learned, dtype=float)), ("W = 0 (feedforward only)", np.zeros(10)),
                  ("the paper's W", PAPER_W), ("LQR of the linearised (6), phi2 = 1.39", lqr_weights(1.39, SotcCore()))]
    costs = [cost_to_go(w, horizon) for _, w in candidates]
    ref = costs[-1]
    return [(label, hjb_residual_ratio(w), float(c.sum()), float(c.sum() / ref.sum()), int(np.sum(c < ref - 1e-12)),
             len(c)) for (label, w), c in zip(candidates, costs)]
