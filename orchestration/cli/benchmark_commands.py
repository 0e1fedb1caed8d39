"""``sotc-cosim benchmark``: a controller FMU from any tool, tuned by the protocol our controllers got and judged on
held-out points against them (docs/benchmark.md, "The benchmark"), on Dask, resumable."""
from __future__ import annotations

import argparse
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import add_cluster, add_fmu_dir, non_negative_int, positive_int
from orchestration.cli.tune_commands import Listener, seed
from orchestration.outputs import PathLock
from orchestration.paths import OUTPUTS, check_output_folder
from orchestration.run import interrupt
from orchestration.run.scenario import ScenarioError


def _problem(path: Path):
    """The controller file at ``path`` as the benchmark's problem, checked against the contract and its search
    space against the FMU first (``ScenarioError``: one line naming the file and the key)."""
    from orchestration.compliance import contract
    from orchestration.run.scenario import controller_instance
    from orchestration.run.search_space import NOTHING_SEARCHED, dimensions
    from orchestration.study.benchmark_problem import Foreign, file_digest
    from orchestration.toml_files import read_toml

    what = str(path)
    if not path.name.endswith(".toml"):
        raise ScenarioError(f"{what}: a controller file (.toml: fmu, ports, parameters, [search]; docs/benchmark.md)")
    inst = controller_instance(path, what)  # its schema, [search]'s shape included
    table = read_toml(path, what, ScenarioError).get("search", {})
    try:
        found = contract.check(inst.file, inst.ports or None, inst.parameters, table)
    except contract.ContractError as exc:
        raise ScenarioError(f"{what}: fmu: {exc}") from None
    if found.problems:
        others = len(found.problems) - 1
        more = f" (and {others} more: sotc-cosim check-controller names them)" if others else ""
        raise ScenarioError(f"{what}: {found.problems[0]}{more}")
    if not table:
        raise ScenarioError(f"{what}: {NOTHING_SEARCHED}")
    md = contract.model_description(inst.file)
    dims = dimensions(md, table)
    start = tuple((v.name, float(v.start)) for v in md.modelVariables if v.name in dims and v.start is not None)
    return Foreign(str(inst.file), file_digest(inst.file), path.stem, tuple(sorted(found.ports.items())),
                   tuple(sorted(inst.parameters.items())), tuple(dims.values()), start)


class _Listener(Listener):
    """The searches' progress (``Listener``), and each seed's held-out runs and J / J* as they follow its search."""

    def evaluating(self, seed: int, tasks: int, kept: int) -> None:
        print(f"{self.label}: seed {seed} searched: {tasks} tasks of held-out runs and J / J* to run, "
              f"{kept} kept in {self.journal.parent}", flush=True)

    def evaluated(self, key: str) -> None:
        print(f"{self.label}: held out: {key} done", flush=True)


def _again(args, seeds: list[int]) -> str:
    again = ["sotc-cosim", "benchmark", str(args.controller), "--budget", str(args.budget), "--polish", str(args.polish),
             "--seeds", *map(str, seeds), "--points", str(args.points), "--out", str(args.out), "--fmu-dir",
             str(args.fmu_dir)]
    again += ["--workers", str(args.workers)] if args.workers else []
    again += ["--scheduler", args.scheduler] if args.scheduler else []
    return " ".join(again)


def _outputs(store: dict, args) -> list[Path]:
    """report.md, the plots and the recording, from the store."""
    from orchestration.outputs import atomic_write
    from orchestration.reports.benchmark_plots import criterion_plot, heldout_plot
    from orchestration.reports.benchmark_report import report

    from orchestration.cli.benchmark_recording import record

    out = args.out
    paths = [atomic_write(out / "report.md", report(store)), criterion_plot(store, out / "criterion.png"),
             heldout_plot(store, out / "heldout.png")]
    return paths + record(store, args.controller, out, args.fmu_dir)


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from orchestration.study.protocol import SEEDS
    from orchestration.sweep.benchmark_jobs import run

    from orchestration.study.benchmark_reference import load as reference

    problem = _problem(args.controller)
    stored = reference()["seeds"]
    if any(s not in stored for s in args.seeds or SEEDS):
        raise ScenarioError(f"--seeds: each seed's design is judged against ours tuned by the same seed; choose from "
                            f"{' '.join(map(str, stored))}")
    if all(d.kind == "choice" for d in problem.dims) and args.polish:
        print("benchmark: every searched parameter is a choice: CMA-ES has nothing to move, so --polish 0")
        args.polish = 0
    args.out = args.out or OUTPUTS / "benchmark" / args.controller.stem
    check_output_folder(args.out, "--out")
    seeds = list(dict.fromkeys(args.seeds or SEEDS))
    settings = {"file": str(args.controller), "budget": args.budget, "polish": args.polish, "seeds": seeds,
                "points": args.points}
    args.out.mkdir(parents=True, exist_ok=True)
    with PathLock(args.out, "--out", folder=True):
        listener = _Listener(args.out / "benchmark.journal", args.workers, args.scheduler, label="benchmark")
        try:
            outcome = run(args.out, problem, settings, args.workers, args.scheduler, listener)
        finally:
            listener.close()
        if outcome.interrupted:
            print(f"interrupted: the finished trials and runs are kept in {args.out}; resume with: {_again(args, seeds)}")
            return interrupt.exit_code()
        for path in _outputs(outcome.store, args):
            print(path)
    return exit_codes.OK


def add_commands(sub) -> None:
    """benchmark."""
    from orchestration.study.protocol import BUDGET, HELD_OUT_POINTS, POLISH, SEEDS

    p = sub.add_parser("benchmark", help="tune a controller FMU from any tool by the one protocol and judge it on "
                                         "held-out points against ours (Optuna, on Dask), resumable")
    p.add_argument("controller", type=Path, metavar="CONTROLLER.toml",
                   help="a controller file: fmu, ports, parameters and the [search] to tune (docs/benchmark.md)")
    p.add_argument("--budget", type=positive_int, default=BUDGET, help=f"TPE trials per seed (default {BUDGET})")
    p.add_argument("--polish", type=non_negative_int, default=POLISH,
                   help=f"then CMA-ES trials from each seed's TPE best, the phase the convergence rule judges "
                        f"(default {POLISH})")
    p.add_argument("--seeds", type=seed, nargs="+", metavar="SEED",
                   help=f"tuning seeds, one independent search each (default {' '.join(map(str, SEEDS))})")
    p.add_argument("--points", type=_points, default=HELD_OUT_POINTS, metavar="N",
                   help=f"held-out points of each draw and set, the first N of the protocol's {HELD_OUT_POINTS} "
                        f"(default {HELD_OUT_POINTS}; fewer: a quick look, marked in the report)")
    add_fmu_dir(p)
    add_cluster(p, ", whose workers share this file system")
    p.add_argument("--out", type=Path, help="the output folder (default recordings/benchmark/<the file's name>); "
                                            "its journal makes a rerun resume")
    p.set_defaults(func=_cmd_benchmark)


def _points(text: str) -> int:
    from orchestration.study.protocol import HELD_OUT_POINTS

    value = positive_int(text)
    if value > HELD_OUT_POINTS:
        raise argparse.ArgumentTypeError(f"{text!r}: at most the protocol's {HELD_OUT_POINTS} points per draw and set")
    return value
