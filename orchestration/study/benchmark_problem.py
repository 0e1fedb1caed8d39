"""A controller FMU from any tool as a tuning problem: what ``optimize`` and ``polish`` search, in the shape of
``tuning.Ours`` (a name, a space, an initial design, a running criterion, a digest), and its runs at the points
of the tuning protocol and of the fair comparison (docs/benchmark.md, "The benchmark").

Every trial and every held-out run steps the FMU against the arm and the reference as cores
(``foreign_loop``), in a child process of this worker that keeps the FMU loaded and resets it between runs
(``foreign_host``): a crash, an exit, a hang or a refusal fails that run only (its criterion infinite, the
reason kept as ``failure``), and the next run gets a new child. The measures are those of ``points.run_point``
for our controllers, in the same arithmetic: MSE_1 + MSE_2 (eq. (50)) over the run, max |e| over its last half.

Everything else is the protocol of ``tuning`` as our controllers get it: the same training points, stop
time, pruning, initial design size, TPE and CMA-ES phases and convergence rule. The initial design is the
FMU's own start values of the searched parameters (each brought into its range), then a scrambled Latin
hypercube of the space, seeded with the tuning seed.
"""
from __future__ import annotations

import atexit
import hashlib
import json
import math
import threading
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from fmu_plant.dynamics import ArmParameters
from fmu_plant.paper_setting import INITIAL_VELOCITIES
from orchestration.run.isolated import ANSWER_S
from orchestration.run.search_space import Dimension
from orchestration.study import tuning
from orchestration.study.foreign_host import ForeignHost
from orchestration.study.pure_loop import Perturbation

# per process (a Dask worker) and thread: one child per FMU, its FMU loaded once (a worker of an existing cluster may
# run tasks on several threads: each gets its own child, whose pipe carries one run at a time)
_HOSTS: dict[tuple, ForeignHost] = {}
_FAILURES: dict[tuple, str] = {}  # per problem and thread: why its last failed run failed
LHS_STREAM = len(tuning.CONTROLLERS)  # the Latin hypercube's generator: [seed, this], apart from our four's


def _close_hosts() -> None:
    for host in _HOSTS.values():
        host.close()
    _HOSTS.clear()


atexit.register(_close_hosts)


@dataclass(frozen=True)
class Foreign:
    """A controller FMU ``fmu`` (an absolute path; ``fmu_digest`` the SHA-256 of its bytes) under the port map
    ``ports`` (None: the contract's names), with ``fixed`` parameters and the searched ``dims``, whose ``start``
    is the FMU's own value of each; ``label`` names its searches. Hashable and picklable: Dask sends it to the
    workers, which each load the FMU once (``host``)."""

    fmu: str
    fmu_digest: str
    label: str
    ports: tuple[tuple[str, str], ...] | None
    fixed: tuple[tuple[str, float], ...]
    dims: tuple[Dimension, ...]
    start: tuple[tuple[str, float], ...]
    answer_s: float = ANSWER_S

    @property
    def name(self) -> str:
        return f"benchmark/{self.label}"

    @property
    def space(self) -> dict[str, Dimension]:
        return {d.name: d for d in self.dims}

    @property
    def failure(self) -> str | None:
        """Why the last failed run of this problem in this thread failed."""
        return _FAILURES.get((self, threading.get_ident()))

    def _failed(self, reason: str) -> None:
        _FAILURES[self, threading.get_ident()] = reason

    @property
    def identity(self) -> str:
        """What its runs depend on besides a design and a point: the FMU's bytes, the map, the fixed parameters and
        the search space (a stored result of another identity is another controller's)."""
        text = json.dumps({"fmu": self.fmu_digest, "ports": self.ports, "fixed": self.fixed,
                           "space": [d.__dict__ for d in self.dims]}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def parameters(self, design: dict[str, float]) -> dict[str, float]:
        """The FMU parameters of a design point: the fixed ones, then the design's."""
        return {**dict(self.fixed), **{k: float(v) for k, v in design.items()}}

    def nominal(self) -> dict[str, float]:
        """The FMU's own start value of each searched parameter, brought into its range (or its first choice)."""
        start = dict(self.start)
        out: dict[str, float] = {}
        for d in self.dims:
            value = start.get(d.name)
            if d.kind == "choice":
                out[d.name] = value if value in d.choices else d.choices[0]
            else:
                value = d.low if value is None or not math.isfinite(value) else min(max(value, d.low), d.high)
                out[d.name] = int(round(value)) if d.kind == "int" else float(value)
        return out

    def initial(self, seed: int) -> list[dict[str, float]]:
        """The nominal design, then ``tuning.INITIAL_DESIGN - 1`` points of a scrambled Latin hypercube."""
        from scipy.stats import qmc

        unit = qmc.LatinHypercube(d=len(self.dims), rng=np.random.default_rng([seed, LHS_STREAM]))
        rows = unit.random(tuning.INITIAL_DESIGN - 1)
        return [self.nominal()] + [{d.name: _from_unit(d, float(u)) for d, u in zip(self.dims, row)} for row in rows]

    def host(self) -> ForeignHost:
        """This process's host of the FMU (started at the first run, restarted by itself after a crash)."""
        key = (self.fmu, self.fmu_digest, self.ports, self.answer_s, threading.get_ident())
        if key not in _HOSTS:
            _HOSTS[key] = ForeignHost(self.fmu, dict(self.ports) if self.ports is not None else None,
                                      answer_s=self.answer_s)
        return _HOSTS[key]

    def measure(self, design: dict[str, float], point: dict[str, Any], stop_time: float) -> dict[str, Any]:
        """One run at a point (``points.run_point``'s measures, None for a run that failed, with ``error``) and
        the samples the actuator cut."""
        run = self.host().run(self.parameters(design), stop_time=stop_time, phi0=tuple(point["phi0"]),
                              dphi0=tuple(point.get("dphi0", INITIAL_VELOCITIES)),
                              arm=ArmParameters(**point["plant"]) if "plant" in point else None,
                              perturbation=Perturbation(**point.get("perturbation", {})), late_from=stop_time / 2)
        if run.failed:
            self._failed(run.error)
            return {"mse": None, "tail": None, "cuts": None, "error": run.error}
        m = run.metrics
        mse, tail = m["mse1"] + m["mse2"], max(m["max_late_e1"], m["max_late_e2"])
        if not (math.isfinite(mse) and math.isfinite(tail)):  # the loop refuses a torque that is not finite: rare
            self._failed(f"the run ended with MSE {mse!r}, max |e| {tail!r}: not finite")
            return {"mse": None, "tail": None, "cuts": run.cuts, "error": self.failure}
        return {"mse": mse, "tail": tail, "cuts": run.cuts, "error": None}

    def running(self, design: dict[str, float]) -> Iterator[float]:
        """``tuning.running_criterion`` of this FMU: after each training point, the geometric mean of
        MSE_1 + MSE_2 so far; inf, and no further point, once a run fails."""
        logs = 0.0
        for k, point in enumerate(tuning.training_points(), start=1):
            mse = self.measure(design, point, tuning.STOP_TIME)["mse"]
            if mse is None or mse <= 0.0:
                if mse is not None:
                    self._failed(f"MSE {mse!r} at training point {k}: no criterion")
                yield math.inf
                return
            logs += math.log(mse)
            yield math.exp(logs / k)

    def criterion(self, design: dict[str, float]) -> float:
        value = math.inf
        for value in self.running(design):
            pass
        return value

    def digest(self, seed: int) -> str:
        """Everything a search's trials depend on besides the loop's code: the FMU's bytes, the map, the fixed
        parameters, the space, the training points and the protocol's numbers."""
        import optuna

        text = json.dumps({"identity": self.identity, "points": tuning.training_points(),
                           "stop": tuning.STOP_TIME, "initial": self.initial(seed), "prune_after": tuning.PRUNE_AFTER,
                           "prune_percentile": tuning.PRUNE_PERCENTILE, "optuna": optuna.__version__.split(".")[0]},
                          sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def _from_unit(d: Dimension, u: float) -> float:
    """The value at ``u`` in [0, 1) of a dimension: its range on its scale, or a choice by stratum."""
    if d.kind == "choice":
        return d.choices[min(int(u * len(d.choices)), len(d.choices) - 1)]
    value = math.exp(math.log(d.low) + u * (math.log(d.high) - math.log(d.low))) if d.log else d.low + u * (d.high - d.low)
    value = min(max(value, d.low), d.high)
    return int(round(value)) if d.kind == "int" else value


def file_digest(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
