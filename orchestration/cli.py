"""``sotc-cosim``: build the FMUs, run scenarios, and report."""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from pathlib import Path

from fmi_slave import VERSION
from orchestration import exit_codes
from orchestration.exit_codes import UsageError
from orchestration.outputs import OutputError, PathLock
from orchestration.fmu_build.build import (
    DEFAULT_FMU_DIR,
    FMU_SOURCES,
    BuildError,
    build_fmus,
    ensure_built,
)
from orchestration.paths import check_output_file, check_output_folder
from orchestration.run import interrupt
from orchestration.run.parameter_check import check_scenarios
from orchestration.run.scenario import MAX_STEPS, ScenarioError, available_scenarios, load_scenario

DEFAULT_SCENARIO = "paper"
MAX_BLOCK = 20_000  # samples per block handed to the recorder at most (about 12 MB of buffers for paper)


def _cmd_build(args: argparse.Namespace) -> int:
    check_output_folder(args.out, "--out")
    from orchestration.fmu_build.compiled import SWITCH, describe, insisted, unavailable

    if insisted() and unavailable():
        print(f"{SWITCH}=1, but the cores stay Python: {unavailable()}")
    for path in build_fmus(args.models or None, args.out):
        print(f"{path}: {describe(path)}")
    return exit_codes.OK


def _cmd_scenarios(args: argparse.Namespace) -> int:
    for name in available_scenarios():
        print(f"{name:<16} {load_scenario(name).description}")
    return exit_codes.OK


def _prepare(names: list, stop_time: float | None, fmu_dir: Path, check=None):
    """Load the scenarios (names, paths or Scenario objects), apply --stop-time, call
    ``check(scenarios)`` (output paths: it raises before anything is built or written), and build the
    FMUs they need."""
    scenarios = [load_scenario(name) if isinstance(name, str) else name for name in names]
    if stop_time is not None:
        scenarios = [s.with_stop_time(stop_time) for s in scenarios]
    if check is not None:
        check(scenarios)
    paths = ensure_built(sorted({i.fmu for s in scenarios for i in s.instances.values()}), fmu_dir)
    check_scenarios(scenarios, paths)  # a value the FMU would refuse: exit 2 before anything runs
    return scenarios, paths


def _run_each(scenarios, paths, recording_for=None, keep_samples: bool = True, record_every: int = 1,
              progress_label: str | None = None) -> list:
    """Run every scenario (a failure is reported and the next one still runs); ``recording_for``
    maps a scenario to the .rrd path its run streams to, or None for no recording;
    ``progress_label``: show the progress under that label. Returns (result, summary) pairs;
    ``keep_samples=False`` streams each run (bounded memory: the summary is computed on the way
    and the result holds no samples)."""
    from orchestration.progress import Progress
    from orchestration.run.master import run
    from orchestration.run.summary import SummaryObserver, summarize

    progress = Progress(len(scenarios), progress_label) if progress_label else None
    out = []
    for scenario in scenarios:
        if interrupt.requested():  # Ctrl-C: no further scenario starts; the finished ones are kept
            break
        target = recording_for(scenario) if recording_for else None
        summary = SummaryObserver()
        observers = [] if keep_samples else [summary]
        if target is None:
            result = run(scenario, paths, observer=observers or None, keep_samples=keep_samples)
        else:
            from orchestration.recording.writer import BLOCK_SIZE, RunRecorder

            # a thinned recording gets proportionally longer blocks: chunks of the usual size, and
            # fewer of them (the recording stream's bookkeeping grows with their number)
            block = min(BLOCK_SIZE * record_every, MAX_BLOCK)
            with RunRecorder(target, every=record_every) as recorder:
                result = run(scenario, paths, observer=[*observers, recorder], block_size=block,
                             keep_samples=keep_samples)
            if recorder.output_error is not None:  # the disk took no more: stop, the finished runs are kept
                raise recorder.output_error
        if result.failed and not result.interrupted:
            print(f"{scenario.name}: FAILED: {result.error}", file=sys.stderr)
        out.append((result, summarize(result) if keep_samples else summary.summary))
        if progress is not None:
            progress.update(not result.failed, f"{scenario.name} {'FAILED' if result.failed else 'ok'}")
    if progress is not None:
        progress.close()
    return out


def _exit_code(summaries: list[dict]) -> int:
    if interrupt.requested():
        return interrupt.exit_code()
    return exit_codes.FAILED if any(s["status"] != "ok" for s in summaries) else exit_codes.OK


def _cmd_run(args: argparse.Namespace) -> int:
    from orchestration.run.summary import format_table, write_summary

    if args.summary and len(args.scenarios) > 1:
        raise ScenarioError("--summary takes one scenario; run them one by one")
    if args.recording and len(args.scenarios) > 1:
        raise ScenarioError("--recording takes one scenario; without it each run writes recordings/<scenario>.rrd")
    def check(scenarios) -> None:
        if args.summary:
            check_output_file(args.summary, "--summary")
        if args.recording:
            check_output_file(args.recording, "--recording")
        elif not args.no_recording:
            from orchestration.recording.writer import default_recording_path

            for scenario in scenarios:
                check_output_file(default_recording_path(scenario.name), "recording")

    scenarios, paths = _prepare(args.scenarios or [DEFAULT_SCENARIO], args.stop_time, args.fmu_dir, check)
    written: list[Path] = []

    def recording_for(scenario):
        if args.no_recording:
            return None
        from orchestration.recording.writer import default_recording_path

        target = args.recording or default_recording_path(scenario.name)
        if target in written:  # the same scenario twice: keep both
            target = target.with_name(f"{target.stem}-{len(written) + 1}{target.suffix}")
        written.append(target)
        return target

    summaries = [s for _, s in _run_each(scenarios, paths, recording_for, keep_samples=False,
                                          record_every=args.record_every)]
    if args.summary:
        write_summary(summaries[0], args.summary)
    print(format_table(summaries))
    for target in written:
        print(f"recording: {target}")
    return _exit_code(summaries)


def _cmd_compare(args: argparse.Namespace) -> int:
    from orchestration.recording.overlays import record_comparison
    from orchestration.run.summary import format_table

    results, summaries = zip(*_run_each(*_prepare(args.scenarios, args.stop_time, args.fmu_dir,
                                                  lambda _: check_output_file(args.recording, "--recording"))))
    print(format_table(summaries))
    print(f"recording: {record_comparison(results, args.recording)}")
    return _exit_code(summaries)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from orchestration.recording.overlays import record_comparison
    from orchestration.study.reproduce import chaos_notes, compact_table, reproduce_scenarios, write_table

    def check(_) -> None:
        check_output_folder(args.out, "--out")
        check_output_file(args.recording, "--recording")

    results, summaries = zip(*_run_each(*_prepare(reproduce_scenarios(), args.stop_time, args.fmu_dir, check),
                                        progress_label="reproduce"))
    notes = chaos_notes(summaries)
    md, cs, text = write_table(summaries, args.out, notes)
    print(text)
    print(compact_table(summaries, notes))
    print(f"wrote {md} and {cs}")
    print(f"recording: {record_comparison(results, args.recording)} (paper Figs 10-12: every run overlaid)")
    return _exit_code(summaries)


class _SweepListener:
    """Prints what a sweep is about to do, then its progress."""

    def __init__(self, sweep, out: Path, workers: int | None, scheduler: str | None):
        self.sweep, self.out, self.workers, self.scheduler = sweep, out, workers, scheduler
        self.progress = None

    def started(self, outcome) -> None:
        from orchestration.progress import Progress

        where = self.scheduler or f"a local Dask cluster of {self.workers or os.cpu_count()} worker processes"
        print(f"sweep {self.sweep.name}: {outcome.total} points, {outcome.skipped} already in {self.out}, "
              f"{outcome.total - outcome.skipped} to run on {where}", flush=True)
        self.progress = Progress(outcome.total, f"sweep {self.sweep.name}", self.workers or os.cpu_count() or 1,
                                 skipped=outcome.skipped, skipped_failed=outcome.skipped_failed)

    def finished(self, row) -> None:
        note = f"point {row['index']} {row['status']}" + (f": {row['reason']}" if row["reason"] else "")
        self.progress.update(row["status"] == "ok", note[:200])

    def close(self) -> None:
        if self.progress is not None:
            self.progress.close()


def _cmd_sweep(args: argparse.Namespace) -> int:
    from orchestration.sweep.spec import grid_from_assignments, load_sweep

    if args.workers is not None and args.workers < 1:
        raise ScenarioError(f"--workers {args.workers}: give at least 1")
    if args.scheduler is not None and not args.scheduler.strip():
        raise ScenarioError("--scheduler '': give a Dask scheduler address such as tcp://host:8786, or leave it out")
    sweep = grid_from_assignments(args.sweep, args.set) if args.set else load_sweep(args.sweep)
    if args.stop_time is not None:
        sweep = dataclasses.replace(sweep, base=sweep.base.with_stop_time(args.stop_time))
    out = check_output_folder(args.out or Path("recordings") / sweep.name, "--out")
    if args.doc:
        check_output_file(args.doc, "--doc")
    existed = out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        with PathLock(out, "--out", folder=True):
            return _sweep_into(args, sweep, out)
    finally:
        if not existed and out.is_dir() and not any(out.iterdir()):
            out.rmdir()  # nothing was stored (the scheduler was unreachable, say): leave no empty folder


def _sweep_into(args: argparse.Namespace, sweep, out: Path) -> int:
    from orchestration.sweep.results import SweepStore, write_doc, write_reports
    from orchestration.sweep.runner import execute

    store = SweepStore(out)
    listener = _SweepListener(sweep, out, args.workers, args.scheduler)
    try:
        outcome = execute(sweep, args.fmu_dir, store, workers=args.workers, scheduler=args.scheduler,
                          record=args.record, retry_failed=args.retry_failed, listener=listener)
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
        print(f"interrupted: the {len(outcome.rows)} finished points are kept in {out}; resume with: "
              f"{' '.join(again)}")
        return interrupt.exit_code()
    if args.doc:
        print(f"doc: {write_doc(store, outcome.total, args.doc)}")
    return exit_codes.FAILED if outcome.failed else exit_codes.OK


def _fmu_files(names: list[str], fmu_dir: Path) -> list[Path]:
    """Model names (built if missing) or paths to .fmu files; none: every FMU of FMU_SOURCES."""
    names = names or list(FMU_SOURCES)
    unknown = [n for n in names if n not in FMU_SOURCES and not Path(n).is_file()]
    if unknown:
        raise BuildError(f"no FMU {unknown}: give a model ({', '.join(FMU_SOURCES)}) or a .fmu path")
    built = ensure_built([n for n in names if n in FMU_SOURCES], fmu_dir)
    return [built[n] if n in FMU_SOURCES else Path(n) for n in names]


def _cmd_validate(args: argparse.Namespace) -> int:
    from orchestration.compliance.validate import format_report, validate_fmus

    report = validate_fmus(_fmu_files(args.fmus, args.fmu_dir))
    print(format_report(report))
    return exit_codes.OK if report.ok else exit_codes.FAILED


def _cmd_cross_check(args: argparse.Namespace) -> int:
    from orchestration.compliance.cross_check import SOURCE_SCENARIO, generate

    check_output_folder(args.out, "--out")
    models = args.models or list(FMU_SOURCES)
    loop = sorted({i.fmu for i in load_scenario(SOURCE_SCENARIO).instances.values()})
    paths = ensure_built(sorted(set(models) | set(loop)), args.fmu_dir)
    for folder in generate(args.out, paths, stop_time=args.stop_time, models=models):
        print(folder)
    return exit_codes.OK


def _cmd_export_ssp(args: argparse.Namespace) -> int:
    from orchestration.compliance.ssp import export_ssp

    check_output_file(args.out, "--out")
    scenario = load_scenario(args.scenario)
    if args.stop_time is not None:
        scenario = scenario.with_stop_time(args.stop_time)
    paths = ensure_built(sorted({i.fmu for i in scenario.instances.values()}), args.fmu_dir)
    print(export_ssp(scenario, paths, args.out))
    return exit_codes.OK


def _cmd_bench(args: argparse.Namespace) -> int:
    from orchestration.bench.command import run_benchmarks
    from orchestration.fmu_build.build import PACKAGE_ROOT
    from orchestration.reports.docgen import SPEED_BLOCKS, store_speed_measurement

    missing = [f for f in SPEED_BLOCKS.values() if not (PACKAGE_ROOT / f).is_file()]
    if args.update_docs and missing:
        raise ScenarioError(f"--update-docs writes {', '.join(SPEED_BLOCKS.values())} of a source checkout; "
                            f"not found next to {PACKAGE_ROOT / 'orchestration'}")
    results = run_benchmarks(args)
    if args.update_docs:
        for path in store_speed_measurement(results["speed"], PACKAGE_ROOT):
            print(f"wrote {path}")
    return exit_codes.OK


def _positive_int(text: str) -> int:
    """A whole number from 1 to MAX_STEPS (the most steps a run may have: no count here needs more)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= MAX_STEPS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number from 1 to {MAX_STEPS}")
    return value


def _time(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number of seconds > 0")
    return value


def _stop_times(text: str) -> list[float]:
    if text.strip().lower() == "none":
        return []
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected stop times like 1000,10000 or 'none', got {text!r}") from None
    if not all(v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"stop times must be > 0, got {text!r}")
    return values


def _add_fmu_dir(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR, help="where FMUs are built and found")


def _add_stop_time(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--stop-time", type=_time, help=help)


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors on one line (the usage itself is one ``-h`` away)."""

    def error(self, message: str):
        self.exit(exit_codes.USAGE, f"{self.prog}: error: {message} (see {self.prog} -h)\n")


def _add_run_commands(sub) -> None:
    """build, run, compare."""
    p = sub.add_parser("build", help="build the FMUs (in a child process)")
    p.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help=f"output folder (default {DEFAULT_FMU_DIR})")
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help=f"FMUs to build (default all: {', '.join(FMU_SOURCES)})")
    p.set_defaults(func=_cmd_build)

    p = sub.add_parser("run", help="run scenarios through the FMUs, print their metrics, record them for Rerun")
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO",
                   help=f"scenario names or .toml paths (default {DEFAULT_SCENARIO})")
    _add_stop_time(p, "override the scenario's stop time, s")
    p.add_argument("--summary", type=Path, help="write the run's summary as JSON to this path")
    _add_fmu_dir(p)
    rec = p.add_mutually_exclusive_group()
    rec.add_argument("--recording", type=Path, metavar="PATH",
                     help="write the Rerun recording here (one scenario; default recordings/<scenario>.rrd)")
    rec.add_argument("--no-recording", action="store_true", help="do not write a Rerun recording")
    p.add_argument("--record-every", type=_positive_int, default=1, metavar="N",
                   help="record every N-th sample only (long runs: a 10,000 s run is about 960 MB at N = 1)")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("compare", help="run scenarios and overlay them in one Rerun recording (paper Figs 10-12)")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario names or .toml paths")
    p.add_argument("--recording", type=Path, metavar="PATH", default=Path("recordings") / "compare.rrd",
                   help="where to write the recording (default recordings/compare.rrd)")
    _add_stop_time(p, "override every scenario's stop time, s")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_compare)


def _add_batch_commands(sub) -> None:
    """sweep, reproduce, bench."""
    p = sub.add_parser("sweep", help="run a sweep file on Dask (a local cluster by default), resumable")
    p.add_argument("sweep", metavar="FILE", help="sweep name (robustness, learning, controllers) or .toml path; "
                   "with --set: a scenario name or path")
    p.add_argument("--set", action="append", default=[], metavar="INSTANCE.PARAM=V1,V2,...",
                   help="sweep FILE as a scenario over these values (several --set: a grid), without a sweep file")
    p.add_argument("--workers", type=_positive_int, help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing dask.distributed scheduler, tcp://host:8786 (default: a local cluster)")
    p.add_argument("--out", type=Path, help="results folder (default recordings/<sweep>); rerun into it to resume")
    p.add_argument("--record", action="store_true", help="write each point's Rerun recording (points/<key>.rrd)")
    p.add_argument("--retry-failed", action="store_true", help="run the stored failed points again")
    p.add_argument("--doc", type=Path, metavar="MD",
                   help="also write the results into this markdown file's generated block (plots beside it)")
    _add_stop_time(p, "the base scenario's stop time, s (an axis over stop_time still sets its own)")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("reproduce", help="run the paper's section 4 experiment and write Table 1 extended")
    p.add_argument("--out", type=Path, default=Path("recordings"), help="where table1.md/.csv go (default recordings/)")
    p.add_argument("--recording", type=Path, metavar="PATH", default=Path("recordings") / "reproduce.rrd",
                   help="the comparison recording of all runs (default recordings/reproduce.rrd)")
    _add_stop_time(p, "override every scenario's stop time, s (default: the paper's 100 s)")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("bench", help="measure speed and scaling (default), or the measurements behind design choices")
    p.add_argument("names", nargs="*", metavar="NAME",
                   help="benchmarks to run: speed (default), integrator, recording, recording-blocks, sweep")
    p.add_argument("--repeats", type=_positive_int, default=3, help="alternated runs of each variant (default 3)")
    p.add_argument("--long", type=_stop_times, default=[1000.0, 10000.0], metavar="S[,S...]",
                   help="stop times of the long single runs, s (default 1000,10000; 'none' skips them)")
    p.add_argument("--record-every", type=_positive_int, default=1, metavar="N",
                   help="the long runs record every N-th sample (default 1: everything)")
    p.add_argument("--json", type=Path, metavar="PATH", help="write the results as JSON (compare them later)")
    p.add_argument("--compare", type=Path, metavar="OLD.json", help="print the change against an earlier --json")
    _add_stop_time(p, "shorten the side-by-side runs of speed (default: the scenario's 100 s)")
    p.add_argument("--update-docs", action="store_true",
                   help="write docs/performance.json and the generated tables of docs/performance.md and README.md")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_bench)


def _add_compliance_commands(sub) -> None:
    """validate, cross-check, export-ssp, scenarios."""
    p = sub.add_parser("validate", help="check FMUs: fmpy, fmutool -check and the project's invariants")
    p.add_argument("fmus", nargs="*", metavar="FMU", help="model names or .fmu paths (default: every FMU)")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_validate)

    p = sub.add_parser("cross-check", help="write a reference run of every FMU in the FMI Cross-Check layout")
    p.add_argument("models", nargs="*", metavar="MODEL", help="FMUs to export (default all)")
    p.add_argument("--out", type=Path, required=True, help="folder that receives fmus/2.0/cs/<platform>/...")
    p.add_argument("--stop-time", type=_time, default=5.0, help="length of each reference run, s (default 5)")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_cross_check)

    p = sub.add_parser("export-ssp", help="write a scenario (FMUs, connections, parameters) as an SSP 1.0 archive")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO, metavar="SCENARIO",
                   help=f"scenario name or .toml path (default {DEFAULT_SCENARIO})")
    p.add_argument("--out", type=Path, required=True, help="the .ssp file to write")
    _add_stop_time(p, "override the scenario's stop time, s")
    _add_fmu_dir(p)
    p.set_defaults(func=_cmd_export_ssp)

    p = sub.add_parser("scenarios", help="list the scenarios that ship with the package")
    p.set_defaults(func=_cmd_scenarios)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="sotc-cosim", description=__doc__)
    parser.add_argument("--version", action="version", version=f"%(prog)s {VERSION}")
    sub = parser.add_subparsers(dest="command", required=True)
    for add in (_add_run_commands, _add_batch_commands, _add_compliance_commands):
        add(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with interrupt.signals_deferred():
        try:
            fmu_dir = getattr(args, "fmu_dir", None)
            if fmu_dir is not None and not fmu_dir.is_dir():  # an existing folder may be read-only: prebuilt
                check_output_folder(fmu_dir, "--fmu-dir")
            code = args.func(args)
        except interrupt.Interrupted:
            code = interrupt.exit_code()
        except (UsageError, BuildError, OutputError, OSError) as exc:
            if interrupt.requested():
                code = interrupt.exit_code()
            else:  # a request that cannot run as given (2); an output that cannot be written (1)
                print(f"sotc-cosim: error: {exc}", file=sys.stderr)
                return exit_codes.USAGE if isinstance(exc, (UsageError, BuildError)) else exit_codes.FAILED
        if interrupt.requested():
            print(f"sotc-cosim: interrupted ({interrupt.signal_name()}): stopped between two steps; finished "
                  "results were kept", file=sys.stderr)
            return interrupt.exit_code()
        return code


if __name__ == "__main__":
    raise SystemExit(main())
