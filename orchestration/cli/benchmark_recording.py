"""The benchmark's recording: its tuned design's `paper` run overlaid on the tuned SOTC's, in the blueprint of
``sotc-cosim compare`` (``recording.overlays``), and the scenario file that reruns the former."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from fmu_controller.saturation import ACCEL
from orchestration.outputs import atomic_write
from orchestration.paths import fmu_folder
from orchestration.run.scenario import load_scenario

SOTC = "SotcController"


def _inline(table: dict) -> str:
    return "{ " + ", ".join(f"{json.dumps(k)} = {json.dumps(v)}" for k, v in table.items()) + " }"


def scenario_text(store: dict, controller_file: Path, seed: str) -> str:
    """A scenario file: `paper` with the benchmarked FMU, its map and its fixed parameters at the tuned design of
    ``seed``, as they were benchmarked (not through the controller file, which may change since)."""
    c = store["controller"]
    parameters = {**c["fixed"], **store["seeds_results"][seed]["search"]["best_design"]}
    ports = f"ports = {_inline(c['ports'])}\n" if c["ports"] is not None else ""
    return (f"# written by sotc-cosim benchmark {controller_file.name}: `sotc-cosim run` this file to run the tuned "
            f"design of seed {seed} again\n"
            f"extends = \"paper\"\nname = {json.dumps(f'{controller_file.stem}-tuned-seed{seed}')}\n\n"
            f"[instances.controller]\nfmu = {json.dumps(c['fmu'])}\n{ports}parameters = {_inline(parameters)}\n")


def record(store: dict, controller_file: Path, out: Path, fmu_dir: Path) -> list[Path]:
    """``scenario.toml`` (the first seed's tuned design) and ``benchmark.rrd`` (its `paper` run beside the tuned
    SOTC's of the same seed, under accel, as the verdicts pair them); a run that failed is said on stderr."""
    from orchestration.cli.run_commands import prepare, run_each
    from orchestration.recording.overlays import record_comparison
    from orchestration.study.tuning import tuned_parameters

    seed = next(iter(store["seeds_results"]))
    scenario_file = atomic_write(out / "scenario.toml", scenario_text(store, controller_file, seed))
    sotc = load_scenario("paper").with_parameters(
        {f"controller.{k}": v for k, v in {**tuned_parameters(SOTC, ACCEL, int(seed)), "limit_handling": float(ACCEL)}.items()},
        name=f"sotc-tuned-seed{seed}")
    scenarios, paths = prepare([str(scenario_file), sotc], None, fmu_folder(fmu_dir, 2))
    results = [r for r, _ in run_each(scenarios, paths)]
    for r in results:
        if r.failed:
            print(f"benchmark: the recorded `paper` run {r.scenario.name} failed: {r.error}", file=sys.stderr)
    return [scenario_file, record_comparison(results, out / "benchmark.rrd")]
