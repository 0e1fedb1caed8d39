"""``sotc-cosim bench``: run the named benchmarks, print their reports, compare with an earlier
JSON and store this one. The measurements themselves live in ``design``, ``speed`` and the modules
``speed`` gathers (``foreign``: the one row also run alone, being short)."""
from __future__ import annotations

import argparse
import json

from orchestration.outputs import atomic_write
from orchestration.bench.design import (
    bench_integrator,
    bench_recording,
    bench_recording_blocks,
    bench_sweep,
)
from orchestration.bench.foreign import foreign_row, line
from orchestration.bench.speed import bench_speed, compare, format_markdown
from orchestration.bench.targets import foreign_targets
from orchestration.markdown import table
from orchestration.exit_codes import UsageError


class BenchError(UsageError):
    """A ``sotc-cosim bench`` request that cannot be run (the CLI prints it in one line, exit 2)."""


def _speed(args) -> tuple[str, dict]:
    data = bench_speed(args.fmu_dir, repeats=args.repeats, long=tuple(args.long), record_every=args.record_every,
                       stop_time=args.stop_time)
    return format_markdown(data), data


def _foreign(args) -> tuple[str, dict]:
    """The speed bench's row of the benchmark's loop with a C controller FMU alone, with its targets: seconds
    where the whole speed bench takes minutes (``--update-docs`` stores it into the stored measurement)."""
    row = foreign_row(args.repeats, args.stop_time)
    judged = foreign_targets(row)
    text = line(row) + ("\n\n" + table(["target", "met"], [[k, "yes" if ok else "**no**"] for k, ok in judged.items()])
                        if judged else "")
    return text, row


def _text_only(bench):
    def run(args) -> tuple[str, dict]:
        text = bench(args.fmu_dir)
        return text, {"benchmark": "text", "text": text}
    return run


# name -> benchmark taking the parsed ``sotc-cosim bench`` arguments, returning (report, JSON data)
BENCHMARKS = {
    "speed": _speed,
    "foreign": _foreign,
    "integrator": _text_only(lambda fmu_dir: bench_integrator()),  # the plant core alone: no FMU
    "recording": _text_only(bench_recording),
    "recording-blocks": _text_only(bench_recording_blocks),
    "sweep": _text_only(bench_sweep),
}
DEFAULT_BENCHMARKS = ("speed",)


def run_benchmarks(args: argparse.Namespace) -> dict[str, dict]:
    """Run ``args.names`` (default: speed), print each report and the comparison with ``--compare``,
    write ``--json``; return name -> JSON data."""
    names = args.names or list(DEFAULT_BENCHMARKS)
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        raise BenchError(f"no benchmark {unknown}; known: {', '.join(BENCHMARKS)}")
    if args.update_docs and not {"speed", "foreign"} & set(names):
        raise BenchError("--update-docs writes the speed benchmark's tables: run it (sotc-cosim bench speed), or "
                         "its row foreign alone (sotc-cosim bench foreign)")
    old = None
    if args.compare is not None:
        try:
            old = json.loads(args.compare.read_text())
        except (OSError, ValueError) as exc:
            raise BenchError(f"--compare {args.compare}: cannot read the JSON of an earlier bench: {exc}") from exc
    results = {}
    for name in names:
        text, results[name] = BENCHMARKS[name](args)
        print(text)
    if old is not None and "speed" in results:
        print(compare(old.get("speed", old), results["speed"]))
    if args.json is not None:
        atomic_write(args.json, json.dumps(results, indent=1) + "\n")
        print(f"wrote {args.json}")
    return results
