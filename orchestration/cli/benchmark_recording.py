"""The benchmark's recording: its tuned design's `paper` run overlaid on the tuned SOTC's, in the blueprint of
``sotc-cosim compare`` (``recording.overlays``), and the scenario file that reruns the former."""
from __future__ import annotations

import json
from pathlib import Path

from fmu_controller.saturation import ACCEL
from orchestration.outputs import atomic_write
from orchestration.paths import fmu_folder
from orchestration.run.scenario import load_scenario

SOTC = "SotcController"


def scenario_text(store: dict, controller_file: Path, seed: str) -> str:
    """A scenario file: `paper` with the controller file's FMU at the tuned design of ``seed``."""
    design = store["seeds_results"][seed]["search"]["best_design"]
    table = ", ".join(f"{json.dumps(k)} = {float(v)!r}" for k, v in design.items())
    return (f"# written by sotc-cosim benchmark: `sotc-cosim run` this file to run the tuned design again\n"
            f"extends = \"paper\"\nname = {json.dumps(f'{controller_file.stem}-tuned-seed{seed}')}\n\n"
            f"[instances.controller]\ncontroller = {json.dumps(str(controller_file.resolve()))}\n"
            f"parameters = {{ {table} }}\n")


def record(store: dict, controller_file: Path, out: Path, fmu_dir: Path) -> list[Path]:
    """``scenario.toml`` (the first seed's tuned design) and ``benchmark.rrd`` (its `paper` run beside the tuned
    SOTC's of the stored search's first seed, under accel)."""
    from orchestration.cli.run_commands import prepare, run_each
    from orchestration.recording.overlays import record_comparison
    from orchestration.study.tuning import stored, tuned_parameters

    seed = next(iter(store["seeds_results"]))
    scenario_file = atomic_write(out / "scenario.toml", scenario_text(store, controller_file, seed))
    ours_seed = stored()["seeds"][0]
    sotc = load_scenario("paper").with_parameters(
        {f"controller.{k}": v for k, v in {**tuned_parameters(SOTC, ACCEL, ours_seed), "limit_handling": float(ACCEL)}.items()},
        name=f"sotc-tuned-seed{ours_seed}")
    scenarios, paths = prepare([str(scenario_file), sotc], None, fmu_folder(fmu_dir, 2))
    results = [r for r, _ in run_each(scenarios, paths)]
    return [scenario_file, record_comparison(results, out / "benchmark.rrd")]
