"""The optimum's initial states on Dask, like a sweep's points: one task per state
(``orchestration.study.optimum_scores.solve_state``: every controller's closed loop, then the optimal
torques under the bound from the best of them), followed on the client as they finish."""
from __future__ import annotations

from dataclasses import dataclass, field

from orchestration.sweep.cluster import follow, open_client, shutdown


@dataclass
class OptimumOutcome:
    records: list = field(default_factory=list)  # solve_state's record of each solved state
    failures: list = field(default_factory=list)  # (index, reason) of each state whose task failed
    interrupted: bool = False


def solve_states(indices: list[int], horizon: float, objective: str, learned: list[float], cold: str,
                 workers: int | None, scheduler: str | None, listener=None) -> OptimumOutcome:
    """``solve_state`` of each index; ``cold`` ("paper", "all", "none") says where to solve again from
    zero torque. ``listener`` (optional) gets ``submitted(n)`` once the tasks are queued and
    ``solved(record)`` or ``failed(index, reason)`` as each ends."""
    from orchestration.study.optimum_scores import solve_state

    outcome, cluster, futures = OptimumOutcome(), None, []
    try:
        cluster = open_client(scheduler, workers)
        futures = [cluster.client.submit(solve_state, i, horizon, objective, learned,
                                         cold == "all" or (cold == "paper" and i == 0), pure=False,
                                         key=f"optimum-state-{i}-{cluster.scratch}") for i in indices]
        index_of = {f.key: i for f, i in zip(futures, indices)}
        if listener is not None:
            listener.submitted(len(futures))

        def done(future) -> None:
            if future.status == "finished":
                outcome.records.append(future.result())
                if listener is not None:
                    listener.solved(outcome.records[-1])
                return
            exc = future.exception()
            outcome.failures.append((index_of[future.key], f"{type(exc).__name__}: {exc}"))
            if listener is not None:
                listener.failed(*outcome.failures[-1])

        outcome.interrupted = follow(futures, done)
    finally:
        shutdown(cluster, futures, outcome.interrupted)
    return outcome
