"""Measurements behind design choices (never timed tests): ``sotc-cosim bench integrator``.

``integrator``: the plant's fixed-step RK4 with N substeps against scipy's DOP853 (rtol 1e-10)
on a 10 s torque profile with the torque held over each 0.01 s step, and the cost of one step.
"""
from __future__ import annotations

import math
import time

import numpy as np

from fmu_plant.dynamics import ArmParameters, forward_dynamics, rk4_step

STEP = 0.01


def excitation_torque(t: float) -> tuple[float, float]:
    """A 10 s torque profile that swings both joints back and forth (N.m)."""
    return 3.0 * math.sin(1.1 * t) + 1.0 * math.cos(3.7 * t), 1.5 * math.cos(0.9 * t) - 0.7 * math.sin(5.3 * t)


def dop853_zoh(state0, torque_at, steps: int, params: ArmParameters = ArmParameters(), step: float = STEP) -> np.ndarray:
    """Reference solution: DOP853 at rtol 1e-10, restarted at each step with the torque held."""
    from scipy.integrate import solve_ivp

    x = np.array(state0, dtype=float)
    out = [x.copy()]
    for k in range(steps):
        t1, t2 = torque_at(k * step)

        def rhs(_t, s, t1=t1, t2=t2):
            return [s[2], s[3], *forward_dynamics(s[1], s[2], s[3], t1, t2, params)]

        x = solve_ivp(rhs, (k * step, (k + 1) * step), x, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
        out.append(x.copy())
    return np.array(out)


def rk4_zoh(state0, torque_at, steps: int, substeps: int, params: ArmParameters = ArmParameters()) -> np.ndarray:
    x = tuple(state0)
    out = [x]
    for k in range(steps):
        x = rk4_step(x, *torque_at(k * STEP), STEP, substeps, params)
        out.append(x)
    return np.array(out)


def bench_integrator() -> str:
    steps = 1000
    state0 = (0.5, -0.5, 0.0, 0.0)
    reference = dop853_zoh(state0, excitation_torque, steps)
    lines = [
        "RK4 with N substeps vs DOP853 (rtol 1e-10), 10 s excitation, torque held per 0.01 s step",
        f"{'N':>3} {'max |phi err| rad':>18} {'max |dphi err| rad/s':>21} {'us per step':>12} {'cost vs N=1':>12}",
    ]
    base = None
    for n in (1, 2, 4, 8):
        traj = rk4_zoh(state0, excitation_torque, steps, n)
        err_q = np.max(np.abs(traj[:, :2] - reference[:, :2]))
        err_w = np.max(np.abs(traj[:, 2:] - reference[:, 2:]))
        x, p = state0, ArmParameters()
        reps = 3000
        t0 = time.perf_counter()
        for _ in range(reps):
            x = rk4_step(state0, 1.0, -0.5, STEP, n, p)
        us = (time.perf_counter() - t0) / reps * 1e6
        base = base or us
        lines.append(f"{n:>3} {err_q:>18.2e} {err_w:>21.2e} {us:>12.1f} {us / base:>12.2f}")
    return "\n".join(lines)


BENCHMARKS = {"integrator": bench_integrator}
