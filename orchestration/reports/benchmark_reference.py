"""Writes the benchmark's reference (``orchestration.study.benchmark_reference``) from the stored fair comparison
and the stored optimum, the one place its numbers come from:

    python -m orchestration.reports.benchmark_reference [--root CHECKOUT]

tests/docs/test_benchmark_reference.py fails when the shipped file differs from what this writes."""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from fmu_controller.catalog import LABELS
from orchestration.outputs import atomic_write
from orchestration.reports import optimum_tables
from orchestration.reports.fair_tables import VERDICT_HANDLING, readme_family
from orchestration.study import fair
from orchestration.study.benchmark_reference import REFERENCE_FILE
from orchestration.study.tuning import CONTROLLERS

ROOT = Path(__file__).resolve().parents[2]


def reference(root: Path) -> dict[str, Any]:
    """Our tuned controllers' held-out measures under the verdict handling (every draw, both sets), the size
    of the README's family on one draw, and the optimum's states with J* and our tuned controllers' J / J*."""
    data = fair.stored(root)
    seeds = data["seeds"]
    runs = {LABELS[fmu]: {str(s): data["runs"][VERDICT_HANDLING][fair.tuned_label(fmu, s)] for s in seeds}
            for fmu in CONTROLLERS}
    optimum = optimum_tables.stored(root)
    tuned = {fair.tuned_label(fmu, s) for fmu in CONTROLLERS for s in seeds}
    return {"handling": VERDICT_HANDLING, "n_points": data["n_points"], "draws": data["draws"],
            "stop_time": data["stop_time"], "seeds": seeds, "family": readme_family(seeds), "runs": runs,
            "optimum": {"horizon": optimum["horizon"], "objective": optimum["objective"],
                        "states": [{"phi0": s["phi0"], "dphi0": s["dphi0"], "J_star": s["J_star"]}
                                   for s in optimum["states"]],
                        "summary": {k: v for k, v in optimum["summary"].items() if k in tuned}}}


def text(root: Path) -> str:
    return json.dumps(reference(root), separators=(",", ":")) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=ROOT, help="the source checkout")
    args = ap.parse_args(argv)
    atomic_write(REFERENCE_FILE, text(args.root))
    print(REFERENCE_FILE)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
