"""``sotc-cosim optimum``: the optimal torque sequence under the bound and every controller's J / J*,
one initial state per Dask task (``orchestration.study.optimum``, ``optimum_scores``)."""
from __future__ import annotations

import argparse
import json
import os
import shutil
import time
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import positive_int, seconds
from orchestration.exit_codes import UsageError
from orchestration.run import interrupt

COLD_CHOICES = ("paper", "all", "none")


def _solve_on_dask(args: argparse.Namespace, indices: list[int], learned: list[float]) -> tuple[list, list, bool]:
    """(records, failures, interrupted): ``solve_state`` of each index on the sweep's Dask client setup."""
    from distributed import as_completed

    from orchestration.outputs import private_folder
    from orchestration.progress import Progress
    from orchestration.study.optimum_scores import solve_state
    from orchestration.sweep.runner import POLL_S, _client, _shutdown

    workers = args.workers or os.cpu_count() or 1
    where = args.scheduler or f"a local Dask cluster of {workers} worker processes"
    print(f"optimum: {len(indices)} initial states, objective {args.objective}, {args.horizon:g} s, on {where}",
          flush=True)
    scratch = f"optimum-{os.getpid()}-{time.time_ns()}"
    client = cluster = None
    futures, records, failures, interrupted = [], [], [], False
    progress = Progress(len(indices), "optimum", workers)
    try:
        client, cluster = _client(args.scheduler, args.workers, scratch)
        futures = [client.submit(solve_state, i, args.horizon, args.objective, learned,
                                 args.cold == "all" or (args.cold == "paper" and i == 0), pure=False,
                                 key=f"optimum-state-{i}-{scratch}") for i in indices]
        index_of = {f.key: i for f, i in zip(futures, indices)}
        pending = as_completed(futures)
        while not pending.is_empty() and not interrupted:
            interrupted = interrupt.requested()
            ready = pending.next_batch(block=False)
            for future in ready:
                if future.status == "finished":
                    rec = future.result()
                    records.append(rec)
                    solver = rec["solver"]
                    progress.update(True, f"state {rec['index']}: J* = {rec['J_star']:.6g} ({solver['seconds']:.1f} s, "
                                          f"{solver['iterations']} iterations)")
                else:
                    exc = future.exception()
                    failures.append((index_of[future.key], f"{type(exc).__name__}: {exc}"))
                    progress.update(False, f"state {index_of[future.key]}: {failures[-1][1]}"[:200])
            if not ready:
                time.sleep(POLL_S)
    finally:
        progress.close()
        _shutdown(client, cluster, futures, interrupted)
        shutil.rmtree(private_folder("scratch") / scratch, ignore_errors=True)
    return records, failures, interrupted


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
    from orchestration.study.optimum_scores import all_states, learned_weights, result

    states = all_states()
    if args.states > len(states):
        raise UsageError(f"--states {args.states}: there are {len(states)} (the paper's and the value study's 16)")
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("--workers and --scheduler: give one (workers start a local cluster)")
    optimum.Problem(*states[0], args.horizon, args.objective)  # a horizon or objective it refuses: exit 2 now
    if args.json:
        check_output_file(args.json, "--json")
    if args.rescore:
        records, failures, interrupted = _rescore(args)
    else:
        records, failures, interrupted = _solve_on_dask(args, list(range(args.states)), learned_weights())
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
    p.add_argument("--workers", type=positive_int, help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing dask.distributed scheduler, tcp://host:8786 (default: a local cluster)")
    p.set_defaults(func=_cmd_optimum)
