"""Perturbations for robustness studies (not in the paper): disturbance torques and measurement noise.

Disturbance torque on joint i, added to tau_i by the plant's input d_i (eq. (1): tau + d)::

    d_i(t) = step_i [t >= step_time] + sin_i sin(omega t)

Measurement noise: zero-mean Gaussian, standard deviation ``std_phi`` on the angles and
``std_dphi`` on the velocities, drawn independently for each joint and each communication point.
The draws are a pure function of (seed, sample index k): block b of ``NOISE_BLOCK`` samples is
``default_rng([seed, b]).standard_normal((NOISE_BLOCK, 4))``, so a run, a rerun, or a run restored
from an FMU state all see the same noise at t_k, whatever happened before.
"""
from __future__ import annotations


import numpy as np

from fmi_slave.parameters import ParameterSpec, nonnegative
from fmu_numerics.elementary import sin


def _torque(name: str, description: str) -> ParameterSpec:
    return ParameterSpec(name, 0.0, "N.m", description, low=-MAX_TORQUE, high=MAX_TORQUE)


MAX_TORQUE = 1e3  # N.m: far beyond the arm's 4 N.m actuator, still a bound (no unbounded input)
DISTURBANCE_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    _torque("step1", "Step disturbance torque on joint 1 from step_time on"),
    _torque("step2", "Step disturbance torque on joint 2 from step_time on"),
    nonnegative("step_time", 0.0, "s", "When the step disturbances start"),
    _torque("sin1", "Amplitude of the sinusoidal disturbance torque on joint 1"),
    _torque("sin2", "Amplitude of the sinusoidal disturbance torque on joint 2"),
    nonnegative("omega", 1.0, "rad/s", "Angular frequency of the sinusoidal disturbances", high=1e4),
)

NOISE_PARAMETER_SPECS: tuple[ParameterSpec, ...] = (
    nonnegative("std_phi", 0.0, "rad", "Standard deviation of the noise on the measured angles", high=10.0),
    nonnegative("std_dphi", 0.0, "rad/s", "Standard deviation of the noise on the measured velocities", high=100.0),
)
NOISE_BLOCK = 1024
MAX_SEED = 999_999


def disturbance_torque(t: float, step1: float, step2: float, step_time: float, sin1: float, sin2: float,
                       omega: float) -> tuple[float, float]:
    on = 1.0 if t >= step_time else 0.0
    s = sin(omega * t)
    return step1 * on + sin1 * s, step2 * on + sin2 * s


class NoiseSequence:
    """Unit Gaussian draws (4 per sample: phi1, phi2, dphi1, dphi2) as a function of the sample index."""

    def __init__(self, seed: int):
        if not 0 <= int(seed) <= MAX_SEED:
            raise ValueError(f"parameter 'seed': {seed} is outside the valid range [0, {MAX_SEED}]")
        self.seed = int(seed)
        self._block_index = -1
        self._block = np.empty((0, 4))
        self._rows: list[list[float]] | None = None  # the block as Python floats, made by the first ``row``

    def at(self, k: int) -> np.ndarray:
        b, i = divmod(int(k), NOISE_BLOCK)
        if b != self._block_index:
            self._block = np.random.default_rng([self.seed, b]).standard_normal((NOISE_BLOCK, 4))
            self._block_index, self._rows = b, None
        return self._block[i]

    def row(self, k: int) -> list[float]:
        """``at(k)`` as Python floats (the same doubles): a loop in Python that reads every sample's draws pays a
        list lookup, not a numpy row and four numpy scalars (several times the arithmetic it feeds)."""
        i = int(k) % NOISE_BLOCK
        if self._rows is None or int(k) // NOISE_BLOCK != self._block_index:
            self.at(k)
            self._rows = self._block.tolist()
        return self._rows[i]
