"""The cost of one tuning trial (``sotc-cosim bench``): the nominal SOTC design run on the whole
training set (``orchestration.study.tuning.criterion``: ``TRAINING_POINTS`` points of ``STOP_TIME``
each in the pure loop), in a fresh interpreter. Twice where the cores can be compiled: with the cores
compiled as a tuning runs them (``compiled_cores``: the hot modules compiled into a private folder by
``fmu_build.compiled``, as an FMU build compiles them, which the child imports first), and with the cores
the interpreter imports by itself (a source checkout: the ``.py``; a plain install: what setup.py compiled
into the wheel). Each reports what its cores ran as.

``python -m orchestration.bench.trial --store-before`` measured the cost on the code before the typed C cores
and stored it in ``trial_before.json`` beside this module, once per kind of cores; the bench compares
each trial with the figure of its kind.
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from orchestration.fmu_build import compiled
from orchestration.fmu_build.build import PACKAGE_ROOT
from orchestration.scratch import owner_prefix

CORES = compiled.CORE_PACKAGES
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


def compiled_cores(dest: Path) -> Path:
    """A copy of the cores' packages in ``dest`` with the hot modules compiled in place, as an FMU build
    compiles them (``compiled.compile_bundle``: the same flags, the ``.pxd`` beside each); a child started in
    ``dest`` imports these extensions before the source tree's ``.py``."""
    for package in CORES:
        (dest / package).mkdir(parents=True)
        for source in (PACKAGE_ROOT / package).glob("*.py"):
            shutil.copyfile(source, dest / package / source.name)
    declarations = {compiled.declarations(rel): (PACKAGE_ROOT / compiled.declarations(rel)).read_text()
                    for rel in compiled.HOT}
    compiled.compile_bundle(dest, ".", declarations)  # the packages at the top: fmu_controller.sotc ...
    return dest


def trial_costs(repeats: int) -> dict[str, dict]:
    """``trial_cost`` with the cores compiled (key "compiled", where they can be) and as the interpreter imports
    them (key "default")."""
    out = {}
    if compiled.unavailable() is None:
        with tempfile.TemporaryDirectory(prefix=owner_prefix("sotc_bench_trial_")) as tmp:
            out["compiled"] = trial_cost(repeats, compiled_cores(Path(tmp)))
    out["default"] = trial_cost(repeats)
    return out


def trial_cost(repeats: int, cwd: Path | None = None) -> dict:
    """Median (min-max) of ``repeats`` trials (each child started in ``cwd``), against the stored cost before
    of the same kind of cores (if stored)."""
    runs = [one_trial(cwd) for _ in range(repeats)]
    walls = [r["wall_s"] for r in runs]
    out = {"median": statistics.median(walls), "min": min(walls), "max": max(walls), "cores": runs[0]["cores"],
           "criterion": runs[0]["criterion"]}
    before = json.loads(BEFORE.read_text()).get(out["cores"]) if BEFORE.is_file() else None
    if before is not None:
        out["before"] = before
        out["cheaper"] = before["median"] / out["median"]
    return out


def trial_line(t: dict, what: str = "One tuning trial (the nominal SOTC design on the 8 training points of 20 s, "
                                     "pure loop") -> str:
    """A ``trial_cost`` as the speed bench prints it (``what``: which trial)."""
    line = f"{what}, cores {t['cores']}, fresh interpreter): {t['median']:.2f} s ({t['min']:.2f}-{t['max']:.2f})"
    if "before" in t:
        b = t["before"]
        line += (f"; before the typed cores {b['median']:.2f} s (cores {b['cores']}, {b.get('date', '?')}): "
                 f"before / now = {t['cheaper']:.2f}")
    return line + "."


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
