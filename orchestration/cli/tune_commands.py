"""``sotc-cosim tune``: the tuning protocol every controller gets (``orchestration.study.tuning``), with
Optuna, on Dask, resumable."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import add_cluster, add_force, non_negative_int, positive_int
from orchestration.outputs import PathLock
from orchestration.paths import OUTPUTS, check_output_file
from orchestration.run import interrupt
from orchestration.run.scenario import ScenarioError

DEFAULT_OUT = OUTPUTS / "tuning" / "tuned.json"
MAX_SEED = 2**31 - 1


def _controllers(names: list[str]) -> list[str]:
    from fmu_controller.catalog import LABELS
    from orchestration.study.tuning import CONTROLLERS

    by_name = {**{c.lower(): c for c in CONTROLLERS}, **{LABELS[c].lower(): c for c in CONTROLLERS}}
    unknown = [n for n in names if n.lower() not in by_name]
    if unknown:
        raise ScenarioError(f"CONTROLLER {unknown[0]!r}: choose from {', '.join(CONTROLLERS)} "
                            f"(or {', '.join(LABELS[c] for c in CONTROLLERS)})")
    chosen = [by_name[n.lower()] for n in names] or list(CONTROLLERS)
    return list(dict.fromkeys(chosen))


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number from 0 to {MAX_SEED}")
    return value


def handling(text: str) -> int:
    from fmu_controller.saturation import LIMIT_HANDLINGS
    from orchestration.study.tuning import HANDLINGS

    names = {LIMIT_HANDLINGS[h]: h for h in HANDLINGS}
    if text not in names:
        raise argparse.ArgumentTypeError(f"{text!r} is not a limit handling; choose from {', '.join(names)}")
    return names[text]


class Listener:
    """The searches' progress on the terminal, under ``label`` (the command's name)."""

    def __init__(self, journal: Path, workers: int | None, scheduler: str | None, label: str = "tune"):
        self.journal, self.workers, self.scheduler, self.label = journal, workers, scheduler, label
        self.progress = None

    def started(self, outcome, total: int) -> None:
        import importlib.machinery

        import fmu_controller.sotc
        from orchestration.progress import Progress
        from orchestration.sweep.cluster import where, worker_count

        if outcome.salvaged is not None:  # one line, before the searches resume without the damaged ones
            print(f"{self.label}: {outcome.salvaged}", file=sys.stderr, flush=True)
        compiled = fmu_controller.sotc.__file__.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))
        cores = ("compiled" if compiled else "Python (an editable install, or SOTC_COSIM_COMPILE=0 at install: "
                 "slower, docs/performance.md)")
        print(f"{self.label}: {outcome.searches} searches, {total} trials, {outcome.trials_before} already in "
              f"{self.journal}, the rest on {where(self.scheduler, self.workers)}; cores {cores}", flush=True)
        # one search is one task: no more run at once than there are searches
        self.progress = Progress(total, self.label, min(worker_count(self.workers), outcome.searches),
                                 skipped=outcome.trials_before)

    def trial(self, search: str) -> None:
        self.progress.update(True, search)

    def close(self) -> None:
        if self.progress is not None:
            self.progress.close()


def _searches_text(data: dict) -> list[str]:
    from orchestration.study.tuning import CONVERGED, improvement, still_improving, tpe_improvement

    def phases(r) -> str:
        if "polish_from" not in r:
            return f"last-half improvement {100 * improvement(r):.2f} %"
        return (f"last-half improvement: TPE {100 * tpe_improvement(r):.2f} %, CMA-ES {100 * improvement(r):.2f} %")

    def verdict(r) -> str:
        if r["trials"] < data["budget"] + data.get("polish", 0):
            return "incomplete"
        return f"{'still improving' if still_improving(r) else 'converged'}: the rule is below {100 * CONVERGED:g} %"

    return [f"{fmu} {h} seed {s}: {r['trials']} trials, best "
            f"{'none' if r['criterion'][r['best']] is None else format(r['criterion'][r['best']], '.6g')}, {phases(r)} "
            f"({verdict(r)})"
            for fmu, c in data["controllers"].items() for h, per in c["handlings"].items() for s, r in per["seeds"].items()]


def _tune_once(args, controllers, handlings, seeds, budget, polish, out, journal):
    from orchestration.sweep.tuning_jobs import tune

    listener = Listener(journal, args.workers, args.scheduler)
    try:
        return tune(out, controllers, handlings, seeds, budget, polish, args.workers, args.scheduler, listener)
    finally:
        listener.close()


def _cmd_tune(args: argparse.Namespace) -> int:
    """Tune at ``--budget`` and ``--polish``; with ``--until-converged CAP``, double the phase the rule judges
    (the CMA-ES phase; the budget when ``--polish 0``) of every search alike while any search still improves
    by ``CONVERGED`` or more over its last half, up to CAP trials."""
    from orchestration.study.journal import JOURNAL
    from orchestration.study.polish import STORE
    from orchestration.study.protocol import SEEDS
    from orchestration.study.tuning import HANDLINGS, unconverged
    from orchestration.sweep.tuning_jobs import journal_of

    controllers = _controllers(args.controllers)
    seeds = list(dict.fromkeys(args.seeds or SEEDS))
    handlings = list(dict.fromkeys(args.handlings or HANDLINGS))
    out = check_output_file(args.out, "--out", kind=STORE, force=args.force)
    journal = check_output_file(journal_of(out), "--out's journal", kind=JOURNAL, force=args.force)
    budget, polish = args.budget, args.polish
    with PathLock(out, "--out"), PathLock(journal, "--out's journal"):  # repair() may then remove Optuna's lock
        while True:
            outcome = _tune_once(args, controllers, handlings, seeds, budget, polish, out, journal)
            still = [] if outcome.interrupted else unconverged(outcome.store)
            judged = polish or budget
            if not still or not args.until_converged or 2 * judged > args.until_converged:
                break
            phase = "CMA-ES phase" if polish else "search"
            print(f"tune: at {judged} trials {len(still)} of {outcome.searches} searches still improve "
                  f"(e.g. {still[0]}): every {phase} goes on to {2 * judged}", flush=True)
            budget, polish = (budget, 2 * polish) if polish else (2 * budget, polish)
    data = outcome.store
    print(f"store: {out} ({'complete' if data['complete'] else 'incomplete'}; journal {journal})")
    print("\n".join(_searches_text(data)))
    if still and args.until_converged and not outcome.interrupted:
        print(f"not converged at {polish or budget} trials, the cap of --until-converged: {', '.join(still)}")
    if outcome.interrupted:
        again = ["sotc-cosim", "tune", *controllers, "--budget", str(budget), "--polish", str(polish),
                 "--seeds", *map(str, seeds),
                 "--handlings", *(h for h in data["controllers"][controllers[0]]["handlings"]), "--out", str(out)]
        again += ["--until-converged", str(args.until_converged)] if args.until_converged else []
        again += ["--workers", str(args.workers)] if args.workers else []
        again += ["--scheduler", args.scheduler] if args.scheduler else []
        print(f"interrupted: the finished trials are kept in {journal}; resume with: {' '.join(again)}")
        return interrupt.exit_code()
    return exit_codes.OK


def add_commands(sub) -> None:
    """tune."""
    from orchestration.study.protocol import BUDGET, CONVERGED, POLISH, SEEDS

    p = sub.add_parser("tune", help="tune the controllers by the one protocol (Optuna, on Dask), resumable")
    p.add_argument("controllers", nargs="*", metavar="CONTROLLER",
                   help="controllers to tune: SotcController CtController LqrController OtcController, or SOTC CT "
                        "LQR OTC (default: all)")
    p.add_argument("--budget", type=positive_int, default=BUDGET,
                   help=f"TPE trials per controller, limit handling and seed (default {BUDGET})")
    p.add_argument("--polish", type=non_negative_int, default=POLISH,
                   help=f"then CMA-ES trials from each search's best, the phase the convergence rule judges; 0: none "
                        f"(default {POLISH})")
    p.add_argument("--until-converged", type=positive_int, metavar="CAP",
                   help="then double the CMA-ES phase (the budget, with --polish 0) of every search alike while any "
                        f"search still improves by {100 * CONVERGED:g} %% or more over the last half of that phase "
                        "(its best-so-far, or the phase's own best), up to CAP trials (docs/baselines.md)")
    p.add_argument("--seeds", type=seed, nargs="+", metavar="SEED",
                   help=f"tuning seeds, one independent search each (default {' '.join(map(str, SEEDS))})")
    p.add_argument("--handlings", type=handling, nargs="+", metavar="HANDLING",
                   help="limit handlings to tune under (default: radial joint accel)")
    add_cluster(p, ", whose workers share this file system")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT,
                   help=f"the store (default {DEFAULT_OUT}); the Optuna journal beside it (its name + .journal) makes a "
                        "rerun resume")
    add_force(p, "a tune store or an Optuna journal")
    p.set_defaults(func=_cmd_tune)
