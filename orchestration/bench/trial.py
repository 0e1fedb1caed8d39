"""The cost of one tuning trial (``sotc-cosim bench``): the nominal SOTC design run on the whole
training set (``orchestration.study.tuning.criterion``: ``TRAINING_POINTS`` points of ``STOP_TIME``
each in the pure loop), in a fresh interpreter, so the cores it runs are those a plain install runs
in-process (compiled into the wheel by setup.py where the build could, else the ``.py``).

``python -m orchestration.bench.trial --store-before`` measured the cost on the code before the typed C cores
and stored it in ``trial_before.json`` beside this module, once per kind of cores (a source
checkout imports the ``.py``; the tree of a plain install, its compiled extensions); the bench
compares with the figure of the same kind.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

BEFORE = Path(__file__).with_name("trial_before.json")
CHILD = (
    "import importlib.machinery, json, time\n"
    "import fmu_controller.sotc\n"
    "from orchestration.study.tuning import criterion, nominal_parameters\n"
    "params = nominal_parameters('SotcController')\n"
    "t0 = time.perf_counter()\n"
    "value = criterion('SotcController', params)\n"
    "wall = time.perf_counter() - t0\n"
    "compiled = fmu_controller.sotc.__file__.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))\n"
    "print(json.dumps({'wall_s': wall, 'criterion': value, 'cores': 'compiled' if compiled else 'Python'}))\n"
)


def one_trial(cwd: Path | None = None) -> dict:
    """Wall seconds of one trial in a child interpreter, its criterion and what its cores ran as."""
    proc = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, cwd=cwd)
    if proc.returncode != 0:
        raise RuntimeError(f"the trial failed: {proc.stderr.strip()[-500:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def trial_cost(repeats: int) -> dict:
    """Median (min-max) of ``repeats`` trials, against the stored cost before (if stored)."""
    runs = [one_trial() for _ in range(repeats)]
    walls = [r["wall_s"] for r in runs]
    out = {"median": statistics.median(walls), "min": min(walls), "max": max(walls), "cores": runs[0]["cores"],
           "criterion": runs[0]["criterion"]}
    before = json.loads(BEFORE.read_text()).get(out["cores"]) if BEFORE.is_file() else None
    if before is not None:
        out["before"] = before
        out["cheaper"] = before["median"] / out["median"]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--store-before", action="store_true", help=f"store this measurement as {BEFORE.name}")
    parser.add_argument("--before", type=Path, default=BEFORE, help="the file to store it in")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    data = trial_cost(args.repeats)
    data.pop("before", None), data.pop("cheaper", None)
    print(json.dumps(data, indent=1))
    if args.store_before:
        data["date"] = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        stored = json.loads(args.before.read_text()) if args.before.is_file() else {}
        args.before.write_text(json.dumps(stored | {data["cores"]: data}, indent=1) + "\n")
        print(f"wrote {args.before}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
