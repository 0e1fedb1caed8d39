"""``sotc-cosim``: build the FMUs, run scenarios, and report."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from orchestration.build import DEFAULT_FMU_DIR, FMU_SOURCES, BuildError, build_fmus, ensure_built
from orchestration.scenario import ScenarioError, available_scenarios, load_scenario

DEFAULT_SCENARIO = "paper"


def _cmd_build(args: argparse.Namespace) -> int:
    for path in build_fmus(args.models or None, args.out):
        print(path)
    return 0


def _cmd_scenarios(args: argparse.Namespace) -> int:
    for name in available_scenarios():
        print(f"{name:<16} {load_scenario(name).description}")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    from orchestration.master import run
    from orchestration.summary import format_table, summarize, write_summary

    scenarios = [load_scenario(name) for name in (args.scenarios or [DEFAULT_SCENARIO])]
    if args.stop_time is not None:
        scenarios = [s.with_stop_time(args.stop_time) for s in scenarios]
    if args.summary and len(scenarios) > 1:
        raise ScenarioError("--summary takes one scenario; run them one by one")
    paths = ensure_built(sorted({i.fmu for s in scenarios for i in s.instances.values()}), args.fmu_dir)
    summaries = []
    for scenario in scenarios:
        result = run(scenario, paths)
        summary = summarize(result)
        summaries.append(summary)
        if result.failed:
            print(f"{scenario.name}: FAILED: {result.error}", file=sys.stderr)
        if args.summary:
            write_summary(summary, args.summary)
    print(format_table(summaries))
    return 1 if any(s["status"] != "ok" for s in summaries) else 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from orchestration.master import run
    from orchestration.reproduce import REPRODUCE_SCENARIOS, compact_table, write_table
    from orchestration.summary import summarize

    scenarios = [load_scenario(name) for name in REPRODUCE_SCENARIOS]
    if args.stop_time is not None:
        scenarios = [s.with_stop_time(args.stop_time) for s in scenarios]
    paths = ensure_built(sorted({i.fmu for s in scenarios for i in s.instances.values()}), args.fmu_dir)
    summaries = []
    for scenario in scenarios:
        result = run(scenario, paths)
        if result.failed:
            print(f"{scenario.name}: FAILED: {result.error}", file=sys.stderr)
        summaries.append(summarize(result))
    md, cs, text = write_table(summaries, args.out)
    print(text)
    print(compact_table(summaries))
    print(f"wrote {md} and {cs}")
    return 1 if any(s["status"] != "ok" for s in summaries) else 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from orchestration.bench import BENCHMARKS

    for name in args.names or list(BENCHMARKS):
        print(BENCHMARKS[name]())
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sotc-cosim", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build", help="build the FMUs (in a child process)")
    p.add_argument("--out", type=Path, default=DEFAULT_FMU_DIR, help=f"output folder (default {DEFAULT_FMU_DIR})")
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help=f"FMUs to build (default all: {', '.join(FMU_SOURCES)})")
    p.set_defaults(func=_cmd_build)

    p = sub.add_parser("run", help="run scenarios through the FMUs and print their metrics")
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO",
                   help=f"scenario names or .toml paths (default {DEFAULT_SCENARIO})")
    p.add_argument("--stop-time", type=float, help="override the scenario's stop time, s")
    p.add_argument("--summary", type=Path, help="write the run's summary as JSON to this path")
    p.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR, help="where FMUs are built and found")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("reproduce", help="run the paper's section 4 experiment and write Table 1 extended")
    p.add_argument("--out", type=Path, default=Path("recordings"), help="where table1.md/.csv go (default recordings/)")
    p.add_argument("--stop-time", type=float, help="override every scenario's stop time, s (default: the paper's 100 s)")
    p.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR, help="where FMUs are built and found")
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("bench", help="measurements behind design choices (prints ratios measured side by side)")
    p.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (default all)")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("scenarios", help="list the scenarios that ship with the package")
    p.set_defaults(func=_cmd_scenarios)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ScenarioError, BuildError) as exc:
        print(f"sotc-cosim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
