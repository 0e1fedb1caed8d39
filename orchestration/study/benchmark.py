"""The benchmark's protocol after the searches: each seed's tuned design judged on the fair comparison's held-out
points and scored on the optimum's states, and the store of it all (docs/benchmark.md, "The benchmark").

* **Held-out runs** (``heldout``): the design at each point of ``fair.evaluation_points`` (every draw, both
  sets, ``fair.EVAL_STOP_TIME`` each), as the stored runs of our tuned controllers
  (``benchmark_reference``) ran there: the same measures, paired point by point. ``points`` below
  ``fair.N_POINTS`` takes the first points of each draw (a quick look, not the protocol, and the report says so).
* **J / J*** (``optimum_costs``): the design's closed loop from each of the stored optimum's states over its
  horizon, scored by the same cost (``optimum.trajectory_cost``) against the stored J*.

Every run goes through ``Foreign.host`` (a child process; a crash fails that run only, with its reason).
"""
from __future__ import annotations

import math
from typing import Any

from orchestration.study import fair
from orchestration.study.benchmark_problem import Foreign
from orchestration.study.benchmark_reference import load as reference

STORE_NAME = "benchmark.json"
JOURNAL_NAME = "benchmark.journal"


def heldout(problem: Foreign, design: dict[str, float], which: str, draw: int, points: int) -> dict[str, Any]:
    """The design's measures at the first ``points`` held-out points of one set and draw, in order (None
    where a run failed; ``errors``: point index -> reason), and the samples the actuator cut per point."""
    out: dict[str, Any] = {name: [] for name in (*fair.MEASURES, "cuts")} | {"errors": {}}
    for i, point in enumerate(fair.evaluation_points(which, draw)[:points]):
        m = problem.measure(design, point, fair.EVAL_STOP_TIME)
        for name in (*fair.MEASURES, "cuts"):
            out[name].append(m[name])
        if m["error"]:
            out["errors"][str(i)] = m["error"]
    return out


def optimum_costs(problem: Foreign, design: dict[str, float]) -> dict[str, Any]:
    """J / J* of the design at each of the stored optimum's states (None where its run failed; ``errors``)."""
    from orchestration.study.optimum import Problem, trajectory_cost

    stored = reference()["optimum"]
    ratios, errors = [], {}
    host = problem.host()
    for i, state in enumerate(stored["states"]):
        oc = Problem(tuple(state["phi0"]), tuple(state["dphi0"]), stored["horizon"], stored["objective"])
        run = host.run(problem.parameters(design), samples=True, stop_time=oc.horizon, phi0=oc.phi0, dphi0=oc.dphi0)
        if run.failed:
            ratios.append(None)
            errors[str(i)] = run.error
            continue
        cost = trajectory_cost(oc, run.samples)
        ratios.append(cost / state["J_star"] if math.isfinite(cost) else None)
    return {"ratios": ratios, "errors": errors}


def heldout_jobs(seeds) -> list[tuple[int, str, int]]:
    """Every (seed, set, draw) the held-out evaluation runs, one task each."""
    return [(s, which, d) for s in seeds for which in fair.SETS for d in fair.DRAWS]


def key(seed: int, which: str, draw: int) -> str:
    return f"seed {seed} / {which} / draw {draw}"


def assemble(problem: Foreign, settings: dict[str, Any], searches: dict[str, Any], heldout_runs: dict[str, Any],
             optimum: dict[str, Any]) -> dict[str, Any]:
    """The store (``STORE_NAME``): what was benchmarked and how, each seed's search record, its held-out runs
    (per set: every draw's points in turn, as ``fair.measure`` reads them) and its J / J*."""
    per_seed = {}
    for seed in settings["seeds"]:
        runs = {which: {name: [v for d in fair.DRAWS for v in heldout_runs[key(seed, which, d)][name]]
                        for name in (*fair.MEASURES, "cuts")} for which in fair.SETS}
        errors = {which: {f"draw {d}, point {i}": e for d in fair.DRAWS
                          for i, e in heldout_runs[key(seed, which, d)]["errors"].items()} for which in fair.SETS}
        per_seed[str(seed)] = {"search": searches[str(seed)], "heldout": runs, "heldout_errors": errors,
                               "optimum": optimum[str(seed)]}
    return {"controller": {"file": settings["file"], "fmu": problem.fmu, "fmu_sha256": problem.fmu_digest,
                           "ports": dict(problem.ports) if problem.ports is not None else None,
                           "fixed": dict(problem.fixed), "search": [d.__dict__ for d in problem.dims]},
            **{k: settings[k] for k in ("budget", "polish", "seeds", "points")},
            "draws": list(fair.DRAWS), "stop_time": fair.EVAL_STOP_TIME, "seeds_results": per_seed}
