"""``sotc-cosim sweep`` and ``bench``: batches on Dask, and the measurements."""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import (add_cluster, add_fmi, add_fmu_dir, add_stop_time, fmu_dir_of, positive_int,
                                       stop_times)
from orchestration.outputs import PathLock
from orchestration.paths import OUTPUTS, check_output_file, check_output_folder
from orchestration.run import interrupt
from orchestration.run.scenario import ScenarioError


class _SweepListener:
    """Prints what a sweep is about to do, then its progress."""

    def __init__(self, sweep, out: Path, workers: int | None, scheduler: str | None):
        self.sweep, self.out, self.workers, self.scheduler = sweep, out, workers, scheduler
        self.progress = None

    def started(self, outcome) -> None:
        from orchestration.progress import Progress

        from orchestration.sweep.cluster import where, worker_count

        print(f"sweep {self.sweep.name}: {outcome.total} points, {outcome.skipped} already in {self.out}, "
              f"{outcome.total - outcome.skipped} to run on {where(self.scheduler, self.workers)}", flush=True)
        self.progress = Progress(outcome.total, f"sweep {self.sweep.name}", worker_count(self.workers),
                                 skipped=outcome.skipped, skipped_failed=outcome.skipped_failed)

    def finished(self, row) -> None:
        note = f"point {row['index']} {row['status']}" + (f": {row['reason']}" if row["reason"] else "")
        self.progress.update(row["status"] == "ok", note[:200])

    def close(self) -> None:
        if self.progress is not None:
            self.progress.close()


def _cmd_sweep(args: argparse.Namespace) -> int:
    from orchestration.sweep.spec import grid_from_assignments, load_sweep

    sweep = grid_from_assignments(args.sweep, args.set) if args.set else load_sweep(args.sweep)
    if args.stop_time is not None:
        sweep = dataclasses.replace(sweep, base=sweep.base.with_stop_time(args.stop_time))
    out = check_output_folder(args.out or OUTPUTS / sweep.name, "--out", locked=True)
    if args.doc:
        check_output_file(args.doc, "--doc")
    created = [f for f in (out, *out.parents) if not f.exists()]  # the folders this sweep makes
    try:
        out.mkdir(parents=True, exist_ok=True)
        with PathLock(out, "--out", folder=True):
            return _sweep_into(args, sweep, out)
    finally:
        for folder in created:  # nothing was stored (the scheduler was unreachable, say): no empty folder
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()


def _sweep_into(args: argparse.Namespace, sweep, out: Path) -> int:
    from orchestration.compliance.contract import check_scenario
    from orchestration.sweep.results import SweepStore, write_doc, write_reports
    from orchestration.sweep.runner import execute

    for point in sweep.points():  # an FMU file with its port map and each point's parameters: exit 2, nothing run
        check_scenario(point.scenario)
    store = SweepStore(out)
    listener = _SweepListener(sweep, out, args.workers, args.scheduler)
    try:
        outcome = execute(sweep, fmu_dir_of(args), store, workers=args.workers, scheduler=args.scheduler,
                          record=args.record, retry_failed=args.retry_failed, listener=listener, fmi=args.fmi)
    finally:
        listener.close()
    reports = write_reports(store, outcome.total)
    print(f"{len(outcome.rows)} of {outcome.total} points stored ({outcome.skipped} from before, {outcome.ran} run now), "
          f"{outcome.failed} failed")
    for name, path in reports.items():
        print(f"{name}: {path}")
    if outcome.interrupted:
        again = ["sotc-cosim", "sweep", args.sweep, *(f"--set={item}" for item in args.set), "--out", str(out)]
        again += ["--workers", str(args.workers)] if args.workers else []
        again += ["--scheduler", args.scheduler] if args.scheduler else []
        again += ["--record"] if args.record else []
        again += ["--stop-time", repr(args.stop_time)] if args.stop_time is not None else []
        again += ["--fmi", "3"] if args.fmi == 3 else []
        print(f"interrupted: the {len(outcome.rows)} finished points are kept in {out}; resume with: "
              f"{' '.join(again)}")
        return interrupt.exit_code()
    if args.doc:
        print(f"doc: {write_doc(store, outcome.total, args.doc)}")
    return exit_codes.FAILED if outcome.failed else exit_codes.OK


def _cmd_bench(args: argparse.Namespace) -> int:
    from orchestration.bench.command import run_benchmarks
    from orchestration.fmu_build.build import PACKAGE_ROOT
    from orchestration.reports.docgen import SPEED_BLOCKS, store_speed_measurement, store_speed_row

    missing = [f for f in SPEED_BLOCKS.values() if not (PACKAGE_ROOT / f).is_file()]
    if args.update_docs and missing:
        raise ScenarioError(f"--update-docs writes {', '.join(SPEED_BLOCKS.values())} of a source checkout; "
                            f"not found next to {PACKAGE_ROOT / 'orchestration'}")
    results = run_benchmarks(args)
    if args.update_docs:
        if "speed" not in results and "skipped" in results["foreign"]:  # a measured row is not replaced by none
            raise ScenarioError(f"--update-docs: the row foreign was not measured: {results['foreign']['skipped']}")
        written = (store_speed_measurement(results["speed"], PACKAGE_ROOT) if "speed" in results
                   else store_speed_row("foreign", results["foreign"], PACKAGE_ROOT))
        for path in written:
            print(f"wrote {path}")
    return exit_codes.OK


def add_commands(sub) -> None:
    """sweep, bench."""
    p = sub.add_parser("sweep", help="run a sweep file on Dask (a local cluster by default), resumable")
    p.add_argument("sweep", metavar="FILE", help="sweep name (robustness, learning, controllers) or .toml path; "
                   "with --set: a scenario name or path")
    p.add_argument("--set", action="append", default=[], metavar="INSTANCE.PARAM=V1,V2,...",
                   help="sweep FILE as a scenario over these values (several --set: a grid), without a sweep file")
    add_cluster(p)
    p.add_argument("--out", type=Path, help="results folder (default recordings/<sweep>); rerun into it to resume")
    p.add_argument("--record", action="store_true", help="write each point's Rerun recording (points/<key>.rrd)")
    p.add_argument("--retry-failed", action="store_true", help="run the stored failed points again")
    p.add_argument("--doc", type=Path, metavar="MD",
                   help="also write the results into this markdown file's generated block (plots beside it)")
    add_stop_time(p, "the base scenario's stop time, s (an axis over stop_time still sets its own)")
    add_fmu_dir(p)
    add_fmi(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("bench", help="measure speed and scaling (default), or the measurements behind design choices")
    p.add_argument("names", nargs="*", metavar="NAME",
                   help="benchmarks to run: speed (default), foreign (speed's row of a C controller FMU in the "
                        "benchmark's loop, alone), integrator, recording, recording-blocks, sweep")
    p.add_argument("--repeats", type=positive_int, default=3, help="alternated runs of each variant, instrumented runs of the cost split and whole-process runs "
                        "(default 3)")
    p.add_argument("--long", type=stop_times, default=[1000.0, 10000.0], metavar="S[,S...]",
                   help="stop times of the long single runs, s (default 1000,10000; 'none' skips them)")
    p.add_argument("--record-every", type=positive_int, default=1, metavar="N",
                   help="the long runs record every N-th sample (default 1: everything)")
    p.add_argument("--json", type=Path, metavar="PATH", help="write the results as JSON (compare them later)")
    p.add_argument("--compare", type=Path, metavar="OLD.json", help="print the change against an earlier --json")
    add_stop_time(p, "shorten the side-by-side runs of speed (default: the scenario's 100 s)")
    p.add_argument("--update-docs", action="store_true",
                   help="write docs/performance.json and the generated tables of docs/performance.md (with foreign "
                        "alone: its row, the rest of the stored measurement kept)")
    add_fmu_dir(p)
    p.set_defaults(func=_cmd_bench)
