"""A small co-simulation loop over built FMUs for tests that need FMI calls between steps
(state save/restore, several instances, reset): same call order as ``orchestration.run.master``.

``loop_models(model)`` picks the FMUs a model is exercised with: the plant and the reference join a
model when they feed at least one of its inputs (every controller then runs in its closed loop);
inputs nothing feeds (the plant's torques when the plant is tested alone) follow a smooth
deterministic signal of time.
"""
from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
from fmpy import read_model_description

from support.fmu_driver import DrivenFmu

T = 0.01
PARTNERS = ("ArmPlant", "ReferenceTrajectory")
_counter = itertools.count()


def ports(fmu_file: Path) -> tuple[list[str], list[str]]:
    md = read_model_description(str(fmu_file))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    return inputs, outputs


def loop_models(model: str, fmu_paths: dict[str, Path]) -> list[str]:
    inputs, _ = ports(fmu_paths[model])
    models = [model]
    for partner in PARTNERS:
        if partner != model and set(inputs) & set(ports(fmu_paths[partner])[1]):
            models.insert(0, partner)
    return models


def drive(name: str, index: int, t: float) -> float:
    """A bounded, smooth test signal for an input nothing feeds."""
    return 0.8 * math.sin(1.7 * t + 0.9 * index) + 0.2 * math.cos(0.6 * t * (index + 1))


class Loop:
    """Instances of ``models`` wired by same-named ports (outputs of one feed inputs of another)."""

    def __init__(self, fmu_paths: dict[str, Path], models: list[str], workdir: Path, tag: str = ""):
        self.models = list(models)
        self.units: dict[str, DrivenFmu] = {}
        for m in self.models:
            unzip = Path(workdir) / f"{m}{tag}-{next(_counter)}"
            self.units[m] = DrivenFmu(fmu_paths[m], unzip, instance_name=f"{m}{tag}")
        self.inputs = {m: [v.name for v in u.md.modelVariables if v.causality == "input"] for m, u in self.units.items()}
        self.outputs = {m: [v.name for v in u.md.modelVariables if v.causality == "output" and v.type == "Real"]
                        for m, u in self.units.items()}
        # (source, target) -> names connected by name
        self.links = {}
        for src, dst in itertools.permutations(self.models, 2):
            names = [n for n in self.outputs[src] if n in self.inputs[dst]]
            if names:
                self.links[(src, dst)] = names
        fed = {(dst, n) for (src, dst), names in self.links.items() for n in names}
        self.driven = {m: [n for n in self.inputs[m] if (m, n) not in fed] for m in self.models}
        feedthrough = {m: any(u.dependencies for u in self.units[m].md.outputs) for m in self.models}
        self.order = sorted(self.models, key=lambda m: feedthrough[m])  # no-feedthrough first
        self.k = 0

    def initialize(self, parameters: dict[str, dict[str, float]] | None = None) -> None:
        for m, unit in self.units.items():
            unit.initialize(**(parameters or {}).get(m, {}))

    def sample(self) -> dict[str, list[float]]:
        """Communication point k: read outputs in feedthrough order, pushing them to their inputs."""
        t = self.k * T
        for m in self.models:
            if self.driven[m]:
                self.units[m].set(**{n: drive(n, i, t) for i, n in enumerate(self.driven[m])})
        row = {}
        for m in self.order:
            values = self.units[m].get(*self.outputs[m])
            row[m] = values
            by_name = dict(zip(self.outputs[m], values))
            for (src, dst), names in self.links.items():
                if src == m:
                    self.units[dst].set(**{n: by_name[n] for n in names})
        return row

    def read(self) -> np.ndarray:
        """Every output of every instance, without pushing anything."""
        return np.concatenate([self.units[m].get(*self.outputs[m]) for m in self.models])

    def advance(self) -> None:
        for m in self.models:
            self.units[m].fmu.doStep(self.k * T, T)
        self.k += 1

    def run(self, steps: int) -> np.ndarray:
        """``steps`` communication steps; returns the samples at t_k .. t_{k+steps-1} (all outputs)."""
        rows = []
        for _ in range(steps):
            row = self.sample()
            rows.append(np.concatenate([row[m] for m in self.models]))
            self.advance()
        return np.array(rows)

    def free(self) -> None:
        for unit in self.units.values():
            if unit.fmu is not None:
                unit.free()
                unit.fmu = None


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
