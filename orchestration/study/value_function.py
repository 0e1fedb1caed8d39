"""How good is a critic W as a value function, and how good is the policy (28) it induces?

Every W is scored at the same points and in the same coordinates. J_hat = W^T zeta(z) and the HJB
equation (22) live in the SOTC's error z = [z_phi, z_v], z_phi = e = phi - phi_d and (chosen reading,
Lambda_1 = I) z_v = e_dot + e - chi_vd*(W): for W = 0 this is the shared z = [e, e_dot + e] (the
README's realised-cost coordinates), for any other W its z_v is shifted by its own chi_vd*.

* HJB residual: e1 of (29), e1 = W^T eta + z^T Theta z + Omega(mu_hat(W)), the residual of (22) for
  J_hat under its own minimising policy (the core's ``e1`` output, PE and CL off). It depends on z and
  phi2 only, and is reported as RMS relative to W = 0's (whose residual is z^T Theta z) over
  (a) ``grid_points``: a grid fixed in z (each component in ``GRID``) at frozen configurations phi2,
      the same z points for every W; (b) ``visited_points``: the (z, phi2) the learning run passes
      through (every ``VISIT_EVERY``-th sample of the run that learned W), whole and for t >= ``SETTLED``;
  and, at fixed physical states instead (whose z moves with W), (c) the grid laid in the shared
  [e, e_dot + e] and (d) the earlier grid laid in (e, e_dot).
* Cost-to-go: from ``N_STATES`` seeded initial states with W frozen (alpha1 = alpha2 = 1e-9, no CL, no
  PE), over ``HORIZON``: the integral of z^T Theta z in the shared z (every W's states weighed alike),
  and the same plus Omega(mu_hat(W)) of (17), each policy paying for its own optimal input (W = 0 has
  mu_hat = 0 and pays none). The earlier figure integrated the core's ``cost_rate``, i.e. in each W's
  own z.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from fmu_controller.sotc import SotcCore
from fmu_plant.trajectory import CircleTrajectory
from orchestration.markdown import stable, table
from orchestration.run.metrics import _trapezoid, ordered_sum
from orchestration.study.ordered import weighted_squares
from orchestration.study.pure_loop import LoopResult, simulate

PHI2_GRID = (0.6, 1.4, 2.2)  # rad, across the circle's range of phi2_d [0.59, 2.19]
GRID = np.linspace(-0.2, 0.2, 5)  # each component of the grid [rad or rad/s]
N_STATES, SPAN, HORIZON, SEED = 16, 0.3, 20.0, 0
VISIT_EVERY, SETTLED = 20, 5.0  # samples between two visited states (0.2 s); the transient's end [s]
FROZEN = {"alpha1": 1e-9, "alpha2": 1e-9, "cl_enabled": 0.0, "pe_amplitude": 0.0}
State = tuple[float, tuple[float, ...], tuple[float, ...]]  # (t, y, r) as the core's evaluate takes them


def _core(W: np.ndarray, **params: float) -> SotcCore:
    return SotcCore(**{f"W0_{k + 1}": float(w) for k, w in enumerate(W)}, **FROZEN, **params)


def state_at(core: SotcCore, z: tuple[float, ...], phi2: float) -> State:
    """The sample (t, y, r), reference at rest, at which the core's error is z with the configuration
    phi2: e = z_phi and e_dot = z_v - Lambda_1 e + chi_vd*(z) (the chosen reading's z_v, eq. (4))."""
    if not core.backstepping:
        raise ValueError("the value measures follow the chosen reading of (4) (chi_a_form backstepping)")
    c1, c2 = core.optimal_virtual_velocity(z)
    (l1, l2), (e1, e2, v1, v2) = core.lam1, z
    return 1.0, (e1, phi2, v1 - l1 * e1 + c1, v2 - l2 * e2 + c2), (0.0, phi2 - e2, 0.0, 0.0, 0.0, 0.0)


def grid_points() -> list[tuple[tuple[float, ...], float]]:
    """(point, phi2) for every point of ``GRID``^4 at each frozen phi2 of ``PHI2_GRID``."""
    return [(p, phi2) for phi2 in PHI2_GRID for p in itertools.product(GRID, repeat=4)]


def physical_states(shared: bool) -> list[State]:
    """The grid read at fixed physical states: (a1, a2, b1, b2) as [e, e_dot + e] (``shared``) or, the
    earlier grid, as (e, e_dot); reference at rest."""
    out = []
    for (a1, a2, b1, b2), phi2 in grid_points():
        de1, de2 = (b1 - a1, b2 - a2) if shared else (b1, b2)
        out.append((1.0, (a1, phi2, de1, de2), (0.0, phi2 - a2, 0.0, 0.0, 0.0, 0.0)))
    return out


def visited_points(run: LoopResult, since: float = 0.0) -> list[tuple[tuple[float, ...], float]]:
    """(z, phi2) at every ``VISIT_EVERY``-th sample of ``run`` from t = ``since`` (z: the core's z1..z4)."""
    z = run.outputs[:, [run.names.index(n) for n in ("z1", "z2", "z3", "z4")]]
    return [(tuple(z[k]), float(run.y[k, 1])) for k in range(0, len(run.t), VISIT_EVERY) if run.t[k] >= since]


def hjb_residuals(W: np.ndarray, states=None, points=None, **params: float) -> np.ndarray:
    """e1 of (29) under W at each of ``states`` (samples) or of ``points`` ((z, phi2), placed with
    ``state_at`` for this W)."""
    core = _core(np.asarray(W, dtype=float), **params)
    k = core.output_names().index("e1")
    samples = states if points is None else [state_at(core, z, phi2) for z, phi2 in points]
    out = np.empty(len(samples))
    for i, (t, y, r) in enumerate(samples):
        core.evaluate(t, y, r)
        out[i] = core.outputs[k]
    return out


def rms(values: np.ndarray) -> float:
    """Root mean square; NaN for no values (a run shorter than ``SETTLED`` visits none after it)."""
    return math.sqrt(float(ordered_sum(values * values)) / values.size) if values.size else math.nan


def initial_states() -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """N_STATES (phi(0), dphi(0)): the path's start plus uniform errors in [-SPAN, SPAN] (seeded)."""
    ref = CircleTrajectory().sample(0.0)
    g = np.random.default_rng(SEED)
    return [((ref[0] + d[0], ref[1] + d[1]), (ref[2] + d[2], ref[3] + d[3])) for d in g.uniform(-SPAN, SPAN, (N_STATES, 4))]


def frozen_runs(W: np.ndarray, horizon: float = HORIZON, **params: float) -> list[LoopResult]:
    """The closed loop under the frozen policy of W from each of ``initial_states()``."""
    return [simulate(_core(np.asarray(W, dtype=float), **params), stop_time=horizon, phi0=phi0, dphi0=dphi0)
            for phi0, dphi0 in initial_states()]


def shared_z(res: LoopResult) -> np.ndarray:
    """z = [e, e_dot + e] at every sample, (N+1, 4)."""
    e, de = res.error, res.y[:, 2:4] - res.ref[:, 2:4]
    return np.hstack([e, de + e])


def own_cost(res: LoopResult) -> float:
    """The earlier cost-to-go: the core's cost_rate, in its own z (z_v moves with W)."""
    return float(_trapezoid(res.out("cost_rate"), res.t))


@dataclass(frozen=True)
class ValueRow:
    label: str
    residuals: tuple[float, ...]  # RMS / W = 0's, in RESIDUAL_HEADER's order
    state_cost: np.ndarray  # per initial state: integral of z^T Theta z, shared z
    omega_cost: np.ndarray  # per initial state: integral of Omega(mu_hat(W))
    cost_earlier: np.ndarray  # per initial state: the core's cost_rate, own z


RESIDUAL_HEADER = ["W", "z grid", "z visited by the learning run", f"same, t >= {SETTLED:g} s",
                   "grid at fixed [e, e_dot + e]", "earlier: grid at fixed (e, e_dot)"]
COST_HEADER = ["W", "z^T Theta z, shared z", "states where below LQR", "+ Omega(mu_hat(W))",
               "earlier: z^T Theta z + Omega in own z"]


def candidates(learned: np.ndarray) -> list[tuple[str, np.ndarray]]:
    from orchestration.study.sotc_study import PAPER_W, lqr_weights

    return [("learned W", np.asarray(learned, dtype=float)), ("W = 0", np.zeros(10)),
            ("the paper's W", PAPER_W), ("LQR", lqr_weights(1.39, SotcCore()))]


LONG_LABELS = {"W = 0": "W = 0 (feedforward only)", "LQR": "LQR of the linearised (6), phi2 = 1.39"}


def value_rows(learned: np.ndarray, learning_run: LoopResult, horizon: float = HORIZON) -> list[ValueRow]:
    """The measures of the module docstring for the learned W (learned in ``learning_run``), W = 0, the
    paper's W and the LQR weights of the linearised (6) at phi2 = 1.39 rad (the cost reference)."""
    named = candidates(learned)
    theta = np.asarray(SotcCore().theta)
    runs = [frozen_runs(w, horizon) for _, w in named]
    measures = (dict(points=grid_points()), dict(points=visited_points(learning_run)),
                dict(points=visited_points(learning_run, SETTLED)),
                dict(states=physical_states(True)), dict(states=physical_states(False)))
    base = [rms(hjb_residuals(np.zeros(10), **m)) for m in measures]
    rows = []
    for (label, w), rs in zip(named, runs):
        residuals = tuple(rms(hjb_residuals(w, **m)) / b for m, b in zip(measures, base))
        state = [float(_trapezoid(weighted_squares(shared_z(r), theta), r.t)) for r in rs]
        omega = [float(_trapezoid(r.out("Omega"), r.t)) for r in rs]
        rows.append(ValueRow(label, residuals, np.array(state), np.array(omega), np.array([own_cost(r) for r in rs])))
    return rows


def residual_cells(rows: list[ValueRow], others: Sequence[list[ValueRow]]) -> list[list[str]]:
    """The residuals of each row, to the digits the same row of every one of ``others`` shares."""
    return [[LONG_LABELS.get(r.label, r.label),
             *(stable(v, [o[i].residuals[j] for o in others], ".3g") for j, v in enumerate(r.residuals))]
            for i, r in enumerate(rows)]


def _relative(rows: list[ValueRow], i: int, cost: Callable[[ValueRow], np.ndarray]) -> float:
    """The summed cost of row i relative to LQR's (the last row)."""
    return float(ordered_sum(cost(rows[i])) / ordered_sum(cost(rows[-1])))


def cost_cells(rows: list[ValueRow], others: Sequence[list[ValueRow]]) -> list[list[str]]:
    """Sums over the initial states relative to LQR's (the last row), at most 4 significant digits, each to
    the digits the same figure of every one of ``others`` shares."""
    def rel(i: int, cost: Callable[[ValueRow], np.ndarray]) -> str:
        return stable(_relative(rows, i, cost), [_relative(o, i, cost) for o in others], ".4g")

    def below(rs: list[ValueRow], i: int) -> int:
        return int(np.sum(rs[i].state_cost < rs[-1].state_cost - 1e-12))

    return [[LONG_LABELS.get(r.label, r.label), rel(i, lambda x: x.state_cost),
             f"{stable(below(rows, i), [below(o, i) for o in others])} of {len(r.state_cost)}",
             rel(i, lambda x: x.state_cost + x.omega_cost), rel(i, lambda x: x.cost_earlier)]
            for i, r in enumerate(rows)]


def _ranking(rows: list[ValueRow], others: Sequence[list[ValueRow]], cost: Callable[[ValueRow], np.ndarray]) -> str:
    order = sorted(range(len(rows)), key=lambda i: float(ordered_sum(cost(rows[i]))))
    return " < ".join(f"{rows[i].label} ({stable(_relative(rows, i, cost), [_relative(o, i, cost) for o in others], '.4g')})"
                      for i in order)


def value_report(rows: list[ValueRow], others: Sequence[list[ValueRow]] = ()) -> str:
    """Both tables and the sentence that resolves each earlier figure, from the same measures; each figure
    to the digits it shares with ``others`` (the rows of the learning run under each perturbation of its
    initial state, ``orchestration.study.comparison.PERTURBATIONS``)."""
    learned, zero = rows[0], rows[1]
    lowest = ", the lowest" if min(rows, key=lambda r: float(ordered_sum(r.cost_earlier))) is zero else ""

    def residual(j: int) -> str:
        return stable(learned.residuals[j], [o[0].residuals[j] for o in others], ".3g")

    earlier = stable(_relative(rows, 1, lambda r: r.cost_earlier), [_relative(o, 1, lambda r: r.cost_earlier)
                                                                    for o in others], ".4g")
    return "\n".join([
        "HJB residual, RMS relative to W = 0's:", "", table(RESIDUAL_HEADER, residual_cells(rows, others)), "",
        "Cost-to-go from the 16 initial states, summed, relative to LQR's:", "",
        table(COST_HEADER, cost_cells(rows, others)), "",
        f"- Residual: the earlier figure (learned W at {residual(-1)} x W = 0's) was taken at fixed "
        "(e, e_dot), which each W maps to other z; at the same z for every W it is "
        f"{residual(0)} on the grid and {residual(1)} on the z the "
        f"learning run visits ({residual(2)} once the transient is over, t >= {SETTLED:g} s).",
        f"- Cost-to-go: the earlier figure (W = 0 at {earlier} x "
        f"LQR's{lowest}) integrated each W's own z, in which W = 0's z_v is not the others'; in the shared z "
        f"the state cost ranks {_ranking(rows, others, lambda r: r.state_cost)}, and with each policy's own "
        f"Omega(mu_hat(W)) added {_ranking(rows, others, lambda r: r.state_cost + r.omega_cost)} (mu_hat(0) = 0 costs "
        "nothing).",
    ])
