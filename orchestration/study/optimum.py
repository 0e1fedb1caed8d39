"""The best tracking any controller could do under the bound: a finite-horizon optimal control problem
on the plant's own model, solved with CasADi (the optional extra ``pip install "sotc-cosim[optimum]"``).

The problem, for one initial state (phi(0), dphi(0)) over ``horizon`` = N T:

* **Decision**: the torques tau_0 .. tau_{N-1}, each held over one sample T (zero-order hold, as the
  master runs every controller), with ||tau_k|| <= rho (section 2.1; rho = ``TORQUE_LIMIT``).
* **Model**: the plant core's own step, ``fmu_plant.dynamics.rk4_step`` with the plant FMU's
  default substeps (``paper_setting.SUBSTEPS``), evaluated symbolically: its ``.py`` is loaded once more with cos, sin and tanh bound to
  CasADi's functions (``symbolic_dynamics``), so the optimiser integrates exactly the formulas of
  eq. (46) the plant runs, with the same constants (``ArmParameters``), not a restatement.
* **Reference**: eqs. (47)-(48) from ``fmu_plant.trajectory.CircleTrajectory`` sampled at t_k (it does
  not depend on the decision, so it enters as numbers).
* **Objective A** (main): the integral over [0, horizon] of z^T Theta z in the shared error
  z = [e, e_dot + e] (e = phi - phi_d; Theta = I, the SOTC's default), by the trapezoid rule over the
  samples t_0 .. t_N, as the value study (``value_function``) and the metrics integrate.
* **Objective B**: A plus sum_k T Omega(tau_k - tau_d(t_k)), Omega of eq. (17) with R = I. Choices
  (ours; the paper charges Omega on the SOTC's own mu only): the *baseline input* is tau_d, the torque
  that keeps the arm on the reference (eq. (1) solved at phi_d, dphi_d, ddphi_d,
  ``dynamics.inverse_dynamics``), so Omega charges what a controller spends beyond following the path;
  the *level* is 2 rho, the smallest level at which Omega is finite for every admissible torque as
  long as ||tau_d|| < rho, since |tau_i - tau_d,i| <= ||tau|| + ||tau_d|| < 2 rho. Where the feedforward
  alone reaches rho somewhere on the horizon (not on the paper's path: max ||tau_d|| = 2.6 N.m), no
  torque can follow the path there and Omega may be undefined: objective B is then refused.

The solution is checked the way a user would: the torques are brought exactly into the disc
(``saturate_norm``, which removes IPOPT's constraint tolerance) and replayed through the sampled loop
every controller runs in (``pure_loop.simulate``: the plant core's ``dynamics.integrate``, what the
plant FMU runs), and J* is the cost of that replay, scored by the
same ``trajectory_cost`` as every controller.
"""
from __future__ import annotations

import functools
import importlib.util
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fmu_controller.saturation import saturate_norm
from fmu_controller.sotc import SotcCore
from fmu_controller.sotc_math import omega_of_mu
from fmu_plant import dynamics
from fmu_plant.dynamics import STEP_SIZE, TORQUE_LIMIT, ArmParameters, inverse_dynamics
from fmu_plant.paper_setting import SUBSTEPS
from fmu_plant.trajectory import CircleTrajectory
from orchestration.exit_codes import UsageError
from orchestration.run.metrics import _trapezoid
from orchestration.study.ordered import weighted_squares
from orchestration.study.pure_loop import LoopResult, simulate
from orchestration.study.value_function import shared_z

OBJECTIVES = ("A", "B")
INPUT_LEVEL = 2.0 * TORQUE_LIMIT  # Omega's saturation level in objective B (module docstring)
INPUT_WEIGHTS = (1.0, 1.0)  # R of eq. (17), the paper's R = 1
TOLERANCE = 1e-10  # IPOPT's tol: J* is reported to far better than the gaps it is compared with
MAX_ITERATIONS = 3000
EXTRA = "optimum"  # the optional dependency group that brings CasADi


def casadi():
    """The casadi module, or a one-line usage error naming the extra to install."""
    try:
        import casadi as ca
    except ImportError:
        raise UsageError(f"the optimum needs CasADi: pip install \"sotc-cosim[{EXTRA}]\"") from None
    return ca


@functools.lru_cache(maxsize=1)
def symbolic_dynamics():
    """A second copy of ``fmu_plant.dynamics`` from its ``.py`` (also when the compiled core is the one
    imported), whose cos, sin, sincos and tanh (``elementary``'s in the core) are CasADi's: its functions then
    accept symbols as well as floats."""
    ca = casadi()
    source = Path(dynamics.__file__).with_name("dynamics.py")
    spec = importlib.util.spec_from_file_location("_optimum_symbolic_dynamics", source)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    module.cos, module.sin, module.tanh = ca.cos, ca.sin, ca.tanh
    module.sincos = lambda x: (ca.sin(x), ca.cos(x))
    return module


def step_function(arm: ArmParameters, substeps: int = SUBSTEPS):
    """F(x, u): one sample T of the plant core's RK4 step, as a CasADi function of the state (4) and
    the held torque (2)."""
    ca = casadi()
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 2)
    new = symbolic_dynamics().rk4_step((x[0], x[1], x[2], x[3]), u[0], u[1], STEP_SIZE, substeps, arm)
    return ca.Function("plant_step", [x, u], [ca.vertcat(*new)])


def omega_symbolic(mu, level: float, weights=INPUT_WEIGHTS):
    """Omega(mu) of eq. (17) on CasADi symbols (mu: 2 x N), summed: the symbolic twin of
    ``sotc_math.omega_of_mu`` (tests/unit/test_optimum.py holds the two equal)."""
    ca = casadi()
    total = 0
    for i, r in enumerate(weights):
        q = mu[i, :] / level
        total += ca.sum2(2.0 * level * r * mu[i, :] * ca.atanh(q) + level * level * r * ca.log1p(-q * q))
    return total


@dataclass(frozen=True)
class Problem:
    """One optimal control problem (module docstring)."""

    phi0: tuple[float, float]
    dphi0: tuple[float, float]
    horizon: float = 20.0
    objective: str = "A"
    arm: ArmParameters = ArmParameters()
    trajectory: CircleTrajectory = CircleTrajectory()

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise UsageError(f"objective {self.objective!r}: choose one of {', '.join(OBJECTIVES)}")
        n = round(self.horizon / STEP_SIZE)
        if n < 1 or abs(n * STEP_SIZE - self.horizon) > 1e-9 * max(1.0, self.horizon):
            raise UsageError(f"horizon {self.horizon:g} s: give a positive multiple of the sample T = {STEP_SIZE} s")
        if self.objective == "B" and float(np.max(np.hypot(*self.baseline().T))) >= TORQUE_LIMIT:
            raise UsageError("objective B: the feedforward that follows the path alone reaches rho on this "
                             "horizon, so Omega of the deviation is not defined for every torque; use objective A")

    @property
    def steps(self) -> int:
        return round(self.horizon / STEP_SIZE)

    @property
    def x0(self) -> tuple[float, float, float, float]:
        return (float(self.phi0[0]), float(self.phi0[1]), float(self.dphi0[0]), float(self.dphi0[1]))

    def times(self) -> np.ndarray:
        return np.arange(self.steps + 1) * STEP_SIZE  # t_k = k T, from the count as the loop does

    @functools.cached_property
    def references(self) -> np.ndarray:
        """``CircleTrajectory.sample`` at every t_k, (N + 1, 8)."""
        return np.array([self.trajectory.sample(float(t)) for t in self.times()])

    def baseline(self) -> np.ndarray:
        """tau_d(t_k), k < N: eq. (1) solved along the reference (objective B's baseline input)."""
        r = self.references
        return np.array([inverse_dynamics(r[k, 1], r[k, 2], r[k, 3], r[k, 4], r[k, 5], self.arm)
                         for k in range(self.steps)])


def theta() -> np.ndarray:
    """The diagonal of Theta (the SOTC's default, I): one source for the NLP and the scores."""
    return np.asarray(SotcCore().theta, dtype=float)


def trajectory_cost(problem: Problem, run: LoopResult, until: float | None = None) -> float:
    """The objective of ``problem`` evaluated on a recorded run from its initial state (a controller's,
    or the optimal torques replayed): trapezoid of z^T Theta z in the shared z, plus the held input
    cost for objective B; over [0, ``until``] only if given. inf where Omega is not defined
    (|tau_i - tau_d,i| >= its level)."""
    k = problem.steps if until is None else min(problem.steps, round(until / STEP_SIZE))
    cost = float(_trapezoid(weighted_squares(shared_z(run), theta())[:k + 1], run.t[:k + 1]))
    if problem.objective == "B":
        mu = run.tau[:k] - problem.baseline()[:k]
        cost += STEP_SIZE * sum(omega_of_mu(m, INPUT_LEVEL, INPUT_WEIGHTS) for m in mu)
    return cost


class _HeldTorques:
    """A controller core of ``pure_loop.simulate`` that holds given torques: tau_k over [t_k, t_k + T),
    the last one again at t_N (recorded, never applied)."""

    def __init__(self, torques: np.ndarray):
        self.torques, self.k, self.outputs = torques, 0, [0.0, 0.0]

    @staticmethod
    def output_names() -> tuple[str, ...]:
        return ("tau1", "tau2")

    def evaluate(self, t: float, y, r) -> None:
        row = self.torques[min(self.k, len(self.torques) - 1)]
        self.outputs, self.k = [float(row[0]), float(row[1])], self.k + 1

    def advance(self, t: float, dt: float) -> None:
        """Nothing learns."""


def replay(problem: Problem, torques: np.ndarray) -> LoopResult:
    """The torques held over each sample through the sampled loop (``pure_loop.simulate``) from the
    problem's initial state; the torque row at t_N repeats the last one (never applied)."""
    return simulate(_HeldTorques(np.asarray(torques, dtype=float)[:problem.steps]), stop_time=problem.horizon,
                    arm=problem.arm, trajectory=problem.trajectory, phi0=problem.phi0, dphi0=problem.dphi0)


def into_disc(torques: np.ndarray) -> np.ndarray:
    """Each torque brought exactly into ||tau|| <= rho (``saturate_norm``: IPOPT honours the constraint
    only to its tolerance)."""
    return np.array([saturate_norm(float(a), float(b), TORQUE_LIMIT)[:2] for a, b in torques])


class Nlp:
    """The multiple-shooting NLP of a problem: variables [x_1 .. x_N, tau_0 .. tau_{N-1}] (x_0 fixed),
    defects x_{k+1} - F(x_k, tau_k) = 0 and ||tau_k||^2 <= rho^2."""

    def __init__(self, problem: Problem):
        ca = casadi()
        n = problem.steps
        self.problem = problem
        X, U = ca.MX.sym("X", 4, n), ca.MX.sym("U", 2, n)  # MX over the mapped SX step: quick to build
        start = ca.DM(problem.x0)
        defects = step_function(problem.arm).map(n)(ca.horzcat(start, X[:, :n - 1]), U) - X
        E = ca.horzcat(start, X) - ca.DM(problem.references[:, :4].T)
        Z = ca.vertcat(E[0:2, :], E[2:4, :] + E[0:2, :])
        dt = np.diff(problem.times())
        w = np.zeros(n + 1)
        w[:-1] += 0.5 * dt
        w[1:] += 0.5 * dt  # the trapezoid weights of _trapezoid
        f = ca.mtimes(ca.mtimes(ca.DM(theta()).T, Z ** 2), ca.DM(w))
        if problem.objective == "B":
            f += STEP_SIZE * omega_symbolic(U - ca.DM(problem.baseline().T), INPUT_LEVEL)
        g = ca.vertcat(ca.vec(defects), ca.sum1(U ** 2).T)
        self.lbg = np.concatenate([np.zeros(4 * n), np.full(n, -np.inf)])
        self.ubg = np.concatenate([np.zeros(4 * n), np.full(n, TORQUE_LIMIT ** 2)])
        # an interior-point trial step outside Omega's domain (objective B) is a NaN IPOPT backtracks from: not news
        options = {"print_time": False, "show_eval_warnings": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                   "ipopt.tol": TOLERANCE, "ipopt.max_iter": MAX_ITERATIONS}
        self.solver = ca.nlpsol("optimum", "ipopt", {"x": ca.vertcat(ca.vec(X), ca.vec(U)), "f": f, "g": g}, options)

    def solve(self, states: np.ndarray, torques: np.ndarray) -> dict:
        """Solve from an initial guess (states x_1 .. x_N as (N, 4), torques (N, 2)); returns the torques
        (N, 2), the solver's objective, its status, iterations and wall time."""
        n = self.problem.steps
        guess = np.concatenate([np.asarray(states, float).reshape(-1), np.asarray(torques, float).reshape(-1)])
        began = time.perf_counter()
        sol = self.solver(x0=guess, lbg=self.lbg, ubg=self.ubg)
        seconds = time.perf_counter() - began
        stats = self.solver.stats()
        x = np.asarray(sol["x"]).reshape(-1)
        return {"torques": x[4 * n:].reshape(n, 2), "objective": float(sol["f"]), "status": stats["return_status"],
                "success": bool(stats["success"]), "iterations": int(stats["iter_count"]), "seconds": seconds}


@dataclass
class Optimum:
    """A solved problem: the optimal torques (inside the disc exactly), J* of their replay, and the
    solver's account."""

    torques: np.ndarray  # (N, 2)
    cost: float  # J*: trajectory_cost of the replay
    solver_objective: float
    status: str
    iterations: int
    seconds: float
    run: LoopResult


def solve(problem: Problem, guess: LoopResult | None = None, nlp: Nlp | None = None) -> Optimum:
    """Solve ``problem`` from a run's trajectory (a controller's: the warm start), or from zero torque and
    the states it gives (the cold start, ``guess=None``); raises RuntimeError when IPOPT fails."""
    nlp = nlp or Nlp(problem)
    n = problem.steps
    if guess is None:
        guess = replay(problem, np.zeros((n, 2)))
    found = nlp.solve(guess.y[1:n + 1], guess.tau[:n])
    if not found["success"]:
        raise RuntimeError(f"IPOPT did not solve the problem from phi0 = {problem.phi0}: {found['status']}")
    torques = into_disc(found["torques"])
    run = replay(problem, torques)
    return Optimum(torques, trajectory_cost(problem, run), found["objective"], found["status"],
                   found["iterations"], found["seconds"], run)
