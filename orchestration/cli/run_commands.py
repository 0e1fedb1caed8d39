"""``sotc-cosim build``, ``scenarios``, ``run``, ``compare`` and ``reproduce``: the scenario commands."""
from __future__ import annotations

import argparse
import shutil
import sys
import textwrap
from pathlib import Path

from orchestration import exit_codes
from orchestration.cli.options import (DEFAULT_SCENARIO, add_fmi, add_fmu_dir, add_force, add_live, add_stop_time,
                                       fmu_dir_of, positive_int)
from orchestration.paths import DEFAULT_FMU_DIR, OUTPUTS, check_output_file, check_output_folder, fmu_folder
from orchestration.recording import RRD
from orchestration.run import interrupt
from orchestration.run.scenario import ScenarioError, available_scenarios, load_scenario

MAX_BLOCK = 20_000  # samples per block handed to the recorder at most (about 12 MB of buffers for paper)


def _cmd_build(args: argparse.Namespace) -> int:
    out = check_output_folder(fmu_folder(args.out, args.fmi, given=args.out is not DEFAULT_FMU_DIR), "--out")
    from orchestration.fmu_build.build import build_fmus, python_only_reason
    from orchestration.fmu_build.compiled import SWITCH, describe, insisted, unavailable

    if insisted() and unavailable():
        print(f"{SWITCH}=1, but the cores stay Python: {unavailable()}")
    why = python_only_reason() or "no hot core in it to compile"
    interrupt.check_before_work()
    for path in build_fmus(args.models or None, out, args.fmi):
        described = describe(path)
        print(f"{path}: {described}" + (f" ({why})" if described == "Python only" else ""))
    return exit_codes.OK


def _cmd_scenarios(args: argparse.Namespace) -> int:
    """One scenario a line (its description wrapped to the terminal, under itself), names in a column as wide
    as the longest."""
    names = available_scenarios()
    width = max(map(len, names), default=0) + 2
    columns = max(shutil.get_terminal_size().columns, width + 40)
    for name in names:
        print(textwrap.fill(load_scenario(name).description, columns, initial_indent=name.ljust(width),
                            subsequent_indent=" " * width))
    return exit_codes.OK


def prepare(names: list, stop_time: float | None, fmu_dir: Path, check=None, fmi: int = 2):
    """Load the scenarios (names, paths or Scenario objects), apply --stop-time, call
    ``check(scenarios)`` (output paths: it raises before anything is built or written), and build the
    FMUs of ours they need (FMI 2.0 or, ``fmi=3``, FMI 3.0); an FMU file a scenario names is checked
    (``contract.check_scenario``) and runs as it is."""
    from orchestration.compliance.contract import check_scenario
    from orchestration.fmu_build.build import ensure_built
    from orchestration.run.parameter_check import check_scenarios

    scenarios = [load_scenario(name) if isinstance(name, str) else name for name in names]
    if stop_time is not None:
        scenarios = [s.with_stop_time(stop_time) for s in scenarios]
    for scenario in scenarios:  # an FMU file and its port map: exit 2 before anything is built or runs
        check_scenario(scenario)
    if check is not None:
        check(scenarios)
    interrupt.check_before_work()  # a signal during the imports: nothing is built
    ours = {i.fmu for s in scenarios for i in s.instances.values() if i.file is None}  # a file runs as it is
    paths = ensure_built(sorted(ours), fmu_dir, fmi)
    check_scenarios(scenarios, paths)  # a value the FMU would refuse: exit 2 before anything runs
    return scenarios, paths


def run_each(scenarios, paths, recording_for=None, keep_samples: bool = True, record_every: int = 1,
              progress_label: str | None = None, writer=None) -> list:
    """Run every scenario (a failure is reported and the next one still runs); ``recording_for``
    maps a scenario to the .rrd path its run streams to, or None for no recording; ``writer``: the
    ``WriterProcess`` that writes them (else this process does);
    ``progress_label``: show the progress under that label. Returns (result, summary) pairs;
    ``keep_samples=False`` streams each run (bounded memory: the summary is computed on the way
    and the result holds no samples)."""
    from orchestration.progress import Progress
    from orchestration.run.isolated import run_any as run
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
            from orchestration.recording import BLOCK_SIZE
            from orchestration.recording.writer_process import recorder_for

            # a thinned recording gets proportionally longer blocks: chunks of the usual size, and
            # fewer of them (the recording stream's bookkeeping grows with their number)
            block = min(BLOCK_SIZE * record_every, MAX_BLOCK)
            with recorder_for(target, record_every, writer) as recorder:
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


def exit_code(summaries: list[dict]) -> int:
    if interrupt.requested():
        return interrupt.exit_code()
    return exit_codes.FAILED if any(s["status"] != "ok" for s in summaries) else exit_codes.OK


def _cmd_run(args: argparse.Namespace) -> int:
    if args.summary and len(args.scenarios) > 1:
        raise ScenarioError("--summary takes one scenario; run them one by one")
    if args.recording and len(args.scenarios) > 1:
        raise ScenarioError("--recording takes one scenario; without it each run writes recordings/<scenario>.rrd")
    if args.no_recording:
        if args.connect or args.serve:
            raise ScenarioError("--connect and --serve stream the recording, which --no-recording does not make")
        return _run_and_report(args, None)
    from orchestration.recording.writer_process import forked_writer

    with forked_writer() as writer:  # first: it imports Rerun while this process loads and runs the FMUs
        return _run_and_report(args, writer)


def _run_and_report(args: argparse.Namespace, writer) -> int:
    from orchestration.recording import default_recording_path
    from orchestration.run.summary import SUMMARY, format_table, write_summary

    def check(scenarios) -> None:
        if args.summary:
            check_output_file(args.summary, "--summary", kind=SUMMARY, force=args.force)
        if args.recording:
            check_output_file(args.recording, "--recording", locked=True, kind=RRD, force=args.force)
        elif not args.no_recording:
            for scenario in scenarios:
                check_output_file(default_recording_path(scenario.name), "recording", locked=True, kind=RRD,
                                  force=args.force)

    scenarios, paths = prepare(args.scenarios or [DEFAULT_SCENARIO], args.stop_time, fmu_dir_of(args), check, args.fmi)
    written: list[Path] = []

    def recording_for(scenario):
        if args.no_recording:
            return None
        target = args.recording or default_recording_path(scenario.name)
        if target in written:  # the same scenario twice: keep both
            target = target.with_name(f"{target.stem}-{len(written) + 1}{target.suffix}")
        written.append(target)
        return target

    summaries = [s for _, s in run_each(scenarios, paths, recording_for, keep_samples=False,
                                          record_every=args.record_every, writer=writer)]
    if args.summary:
        write_summary(summaries[0], args.summary)
    print(format_table(summaries))
    for target in written:
        print(f"recording: {target}")
    return exit_code(summaries)


def _check_recording(args: argparse.Namespace, within: Path | None = None) -> None:
    """``--recording`` of compare and reproduce: a Rerun recording, or any file with ``--force``; it may go
    into ``within``, the command's own ``--out`` folder, before that folder is made."""
    check_output_file(args.recording, "--recording", locked=True, kind=RRD, force=args.force, within=within)


def _cmd_compare(args: argparse.Namespace) -> int:
    from orchestration.recording.overlays import record_comparison
    from orchestration.run.summary import format_table

    results, summaries = zip(*run_each(*prepare(args.scenarios, args.stop_time, fmu_dir_of(args),
                                                  lambda _: _check_recording(args), args.fmi),
                                           progress_label="compare"))  # a line per run: it was silent for 66 s
    print(format_table(summaries))
    print(f"recording: {record_comparison(results, args.recording)}")
    return exit_code(summaries)


def _also(names: list[str]) -> list:
    """The scenarios of ``--with`` (a controller of one's own beside ours: every table, the recording), each
    under a name no run of reproduce has."""
    from orchestration.study.reproduce import REPRODUCE_SCENARIOS

    scenarios, taken = [], set(REPRODUCE_SCENARIOS)
    for name in names:
        scenario = load_scenario(name)
        if scenario.name in taken:
            raise ScenarioError(f"--with {name}: its name '{scenario.name}' is already a run of this reproduce; "
                                "give the scenario file another name = \"...\"")
        taken.add(scenario.name)
        scenarios.append(scenario)
    return scenarios


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from orchestration.recording.overlays import record_comparison
    from orchestration.study.reproduce import chaos_notes, compact_table, reproduce_scenarios, write_table

    def check(_) -> None:
        check_output_folder(args.out, "--out")
        _check_recording(args, within=args.out)

    scenarios = [*reproduce_scenarios(), *_also(args.also)]
    results, summaries = zip(*run_each(*prepare(scenarios, args.stop_time, fmu_dir_of(args), check, args.fmi),
                                        progress_label="reproduce"))
    notes = chaos_notes(summaries)
    md, cs = write_table(summaries, args.out, notes)
    print(compact_table(summaries, notes))
    print(f"wrote {md} (every column)\nwrote {cs}")
    print(f"recording: {record_comparison(results, args.recording)} (paper Figs 10-12: every run overlaid)")
    return exit_code(summaries)


def add_commands(sub) -> None:
    """build, run, compare, reproduce, scenarios."""
    p = sub.add_parser("build", help="build the FMUs (in a child process)")
    p.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help=f"output folder (default {DEFAULT_FMU_DIR})")
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help="FMUs to build (default all; an unknown name gets the list of known ones)")
    add_fmi(p, "build")
    p.set_defaults(func=_cmd_build)

    p = sub.add_parser("run", help="run scenarios through the FMUs, print their metrics, record them for Rerun")
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO",
                   help=f"scenario names or .toml paths (default {DEFAULT_SCENARIO})")
    add_stop_time(p, "override the scenario's stop time, s")
    p.add_argument("--summary", type=Path, help="write the run's summary as JSON to this path")
    add_fmu_dir(p)
    rec = p.add_mutually_exclusive_group()
    rec.add_argument("--recording", type=Path, metavar="PATH",
                     help="write the Rerun recording here (one scenario; default recordings/<scenario>.rrd)")
    rec.add_argument("--no-recording", action="store_true", help="do not write a Rerun recording")
    p.add_argument("--record-every", type=positive_int, default=1, metavar="N",
                   help="record every N-th sample only (long runs: a 10,000 s run is about 960 MB at N = 1)")
    add_force(p, f"{RRD.name} or a run summary")
    add_fmi(p)
    add_live(p)
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("compare", help="run scenarios and overlay them in one Rerun recording (paper Figs 10-12)")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario names or .toml paths")
    p.add_argument("--recording", type=Path, metavar="PATH", default=OUTPUTS / "compare.rrd",
                   help="where to write the recording (default recordings/compare.rrd)")
    add_force(p, RRD.name)
    add_stop_time(p, "override every scenario's stop time, s")
    add_fmu_dir(p)
    add_fmi(p)
    add_live(p)
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser("reproduce", help="run the paper's section 4 experiment and write Table 1 extended")
    p.add_argument("--out", type=Path, default=OUTPUTS, help="where table1.md/.csv go (default recordings/)")
    p.add_argument("--recording", type=Path, metavar="PATH", default=OUTPUTS / "reproduce.rrd",
                   help="the comparison recording of all runs (default recordings/reproduce.rrd)")
    p.add_argument("--with", dest="also", action="append", default=[], metavar="SCENARIO",
                   help="also run this scenario (a name or .toml, e.g. one whose controller is an FMU file of your "
                   "own) and give it its row in every table and its place in the recording; may be repeated")
    add_force(p, RRD.name)
    add_stop_time(p, "override every scenario's stop time, s (default: the paper's 100 s)")
    add_fmu_dir(p)
    add_fmi(p)
    add_live(p)
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("scenarios", help="list the scenarios that ship with the package")
    p.set_defaults(func=_cmd_scenarios)
