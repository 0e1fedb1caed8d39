"""``sotc-cosim optimum``: the optimal torque sequence under the bound and every controller's J / J*,
one initial state per Dask task (``orchestration.study.optimum``, ``optimum_scores``)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import add_cluster, positive_int, seconds
from orchestration.exit_codes import UsageError
from orchestration.run import interrupt

COLD_CHOICES = ("paper", "all", "none")


class _Listener:
    """Says what the optimum does from its first second on (each solve takes minutes), then a line per state."""

    def __init__(self, args: argparse.Namespace, states: int):
        from orchestration.sweep.cluster import where, worker_count

        self.states, self.progress = states, None
        self.running = min(worker_count(args.workers), states)
        print(f"optimum: {states} initial states, objective {args.objective}, {args.horizon:g} s, on "
              f"{where(args.scheduler, args.workers)}; first the weights the paper run learns in 100 s", flush=True)

    def submitted(self, n: int) -> None:
        from orchestration.progress import Progress

        print(f"optimum: solving {n} states, {self.running} at a time (minutes each: every controller's run, "
              f"then the solver); a line as each state ends", flush=True)
        self.progress = Progress(n, "optimum", self.running)

    def solved(self, rec: dict) -> None:
        solver = rec["solver"]
        self.progress.update(True, f"state {rec['index']}: J* = {rec['J_star']:.6g} ({solver['seconds']:.1f} s, "
                                   f"{solver['iterations']} iterations)")

    def failed(self, index: int, reason: str) -> None:
        self.progress.update(False, f"state {index}: {reason}"[:200])

    def close(self) -> None:
        if self.progress is not None:
            self.progress.close()


def _solve_on_dask(args: argparse.Namespace, indices: list[int]) -> tuple[list, list, bool]:
    """(records, failures, interrupted) of the states ``indices`` (``orchestration.sweep.optimum_jobs``)."""
    from orchestration.study.optimum_scores import learned_weights
    from orchestration.sweep.optimum_jobs import solve_states

    listener = _Listener(args, len(indices))
    try:
        out = solve_states(indices, args.horizon, args.objective, learned_weights(), args.cold, args.workers,
                           args.scheduler, listener)
    finally:
        listener.close()
    return out.records, out.failures, out.interrupted


def _rescore(args: argparse.Namespace) -> tuple[list, list, bool]:
    """``--rescore``: the stored states of ``--json``, every controller's J computed again (same horizon
    and objective), J* and the optimal torques kept."""
    from orchestration.progress import Progress
    from orchestration.study.optimum_scores import learned_weights, rescore_state

    if not args.json or not args.json.is_file():
        raise UsageError("--rescore needs --json PATH of an earlier result to rescore")
    try:
        stored = json.loads(args.json.read_text())
    except (OSError, ValueError) as exc:
        raise UsageError(f"--json {args.json}: not a stored optimum result ({exc})") from None
    if (stored.get("horizon"), stored.get("objective")) != (args.horizon, args.objective):
        raise UsageError(f"--json {args.json} holds horizon {stored.get('horizon')} s, objective "
                         f"{stored.get('objective')}: give the same --horizon and --objective")
    learned, records = learned_weights(), []
    progress = Progress(len(stored["states"]), "rescore", 1)
    try:
        for record in stored["states"]:
            if interrupt.requested():
                return records, [], True
            records.append(rescore_state(record, args.horizon, args.objective, learned))
            progress.update(True, f"state {record['index']}")
    finally:
        progress.close()
    return records, [], False


def _cmd_optimum(args: argparse.Namespace) -> int:
    from orchestration.study import optimum

    optimum.casadi()  # without the extra: one line naming it, exit 2, before anything starts
    from orchestration.outputs import atomic_write
    from orchestration.paths import check_output_file
    from orchestration.reports.optimum_tables import summary_table
    from orchestration.study.optimum_scores import all_states, result

    states = all_states()
    if args.states > len(states):
        raise UsageError(f"--states {args.states}: there are {len(states)} (the paper's and the value study's 16)")
    optimum.Problem(*states[0], args.horizon, args.objective)  # a horizon or objective it refuses: exit 2 now
    if args.json:
        check_output_file(args.json, "--json")
    if args.rescore:
        records, failures, interrupted = _rescore(args)
    else:
        records, failures, interrupted = _solve_on_dask(args, list(range(args.states)))
    data = result(records, args.horizon, args.objective)
    if records:
        paper = next((s for s in data["states"] if s["index"] == 0), None)
        if paper is not None:
            print(f"J* at the paper's initial state: {paper['J_star']:.6g}")
        print(summary_table(data))
    for index, reason in sorted(failures):
        print(f"state {index}: the solver failed: {reason}")
    if args.json:
        data["failures"] = [{"index": i, "reason": r} for i, r in sorted(failures)]
        text = json.dumps(data, separators=(",", ":")) + "\n"  # compact: 2000 torques a state
        print(f"json: {atomic_write(args.json, text)}")
    if interrupted:
        return interrupt.exit_code()
    return exit_codes.FAILED if failures else exit_codes.OK


def add_commands(sub) -> None:
    """optimum."""
    p = sub.add_parser("optimum", help="solve the optimal tracking problem under the bound (CasADi) and score "
                                       "every controller against it, J / J*")
    p.add_argument("--horizon", type=seconds, default=20.0, metavar="S",
                   help="horizon, s (default 20, a multiple of T)")
    p.add_argument("--states", type=positive_int, default=17, metavar="N",
                   help="the first N initial states: the paper's, then the value study's 16 (default 17)")
    p.add_argument("--objective", choices=("A", "B"), default="A",
                   help="A: integral of z^T Theta z (default); B: A plus Omega (17) of tau - tau_d")
    p.add_argument("--cold", choices=COLD_CHOICES, default="paper",
                   help="where to solve again from zero torque as a check (default: the paper's state)")
    p.add_argument("--json", type=Path, metavar="PATH", help="write J*, every J and the optimal torques per state")
    p.add_argument("--rescore", action="store_true",
                   help="keep the optimum stored in --json and compute every controller's J again (after a new "
                        "tuning: J* does not depend on the controllers)")
    add_cluster(p)
    p.set_defaults(func=_cmd_optimum)
