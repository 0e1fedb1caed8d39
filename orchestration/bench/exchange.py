"""The FMI 3.0 arm's Model Exchange interface against its co-simulation interface (RK4), measured:

- ``free``: two seconds of the arm alone, initial speed [1, -1] rad/s, zero torque, run by
  ``fmpy.simulate_fmu`` with CVODE (relative tolerance ``REL_TOL``) and as co-simulation;
- ``loop``: the ``paper`` closed loop (100 s) with the Model Exchange arm (``interface =
  "ModelExchange"``, ``orchestration.run.fmi3_exchange``) and with the co-simulation arm.

    python -m orchestration.bench.exchange [--fmu-dir DIR]

stores the measurement in ``docs/exchange.json`` and rewrites the generated block ``exchange`` of
``docs/interop.md`` from it (docgen checks that block against the stored file).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from orchestration.markdown import number, replace_block, table
from orchestration.outputs import atomic_write

MEASUREMENT = "docs/exchange.json"
DOC_BLOCK = ("exchange", "docs/interop.md")
REL_TOL = 1e-10
FREE_SECONDS = 2.0
LOOP_SCENARIO = "paper"


def free_arm(arm_fmu: Path) -> dict[str, float]:
    """The largest |difference| of phi and dphi at the end of the free run, ME against co-simulation."""
    import fmpy

    common = dict(stop_time=FREE_SECONDS, output_interval=0.01, output=["phi", "dphi"],
                  start_values={"dphi1_0": 1.0, "dphi2_0": -1.0})
    me = fmpy.simulate_fmu(str(arm_fmu), fmi_type="ModelExchange", relative_tolerance=REL_TOL, **common)
    cs = fmpy.simulate_fmu(str(arm_fmu), fmi_type="CoSimulation", **common)
    return {name: float(np.max(np.abs(np.asarray(me[-1][name]) - np.asarray(cs[-1][name])))) for name in ("phi", "dphi")}


def closed_loop(paths: dict[str, Path]) -> dict[str, object]:
    """MSE of both arms in the paper loop, and the largest |phi| gap between them over the run."""
    from orchestration.run.master import run
    from orchestration.run.scenario import load_scenario
    from orchestration.run.summary import summarize

    scenario = load_scenario(LOOP_SCENARIO)
    plant = scenario.instances["plant"]
    exchange = dataclasses.replace(scenario, instances={**scenario.instances,
                                                        "plant": dataclasses.replace(plant, interface="ModelExchange")})
    rk4, me = run(scenario, paths), run(exchange, paths)
    for result in (rk4, me):
        if result.failed:
            raise RuntimeError(f"the {LOOP_SCENARIO} loop failed: {result.error}")
    gap = max(float(np.max(np.abs(me.outputs["plant"][n] - rk4.outputs["plant"][n]))) for n in ("phi1", "phi2"))
    return {"mse_rk4": summarize(rk4)["mse"], "mse_exchange": summarize(me)["mse"], "max_phi_gap": gap,
            "seconds": scenario.stop_time}


def measure(fmu_dir: Path) -> dict[str, object]:
    from orchestration.fmu_build.build import FMU_SOURCES, ensure_built

    paths = ensure_built(list(FMU_SOURCES), fmu_dir, fmi=3)
    return {"rel_tol": REL_TOL, "free": free_arm(paths["ArmPlant"]), "loop": closed_loop(paths)}


def stored_block(root: Path) -> str:
    """The table of the stored measurement, as docgen renders it."""
    data = json.loads((root / MEASUREMENT).read_text())
    free, loop = data["free"], data["loop"]
    rel = [abs(a - b) / b for a, b in zip(loop["mse_exchange"], loop["mse_rk4"])]
    rows = [[f"arm alone, {FREE_SECONDS:g} s, dphi(0) = [1, -1] rad/s, zero torque (fmpy.simulate_fmu)",
             f"{free['phi']:.1e} rad, {free['dphi']:.1e} rad/s (at the end)", "-"],
            [f"`{LOOP_SCENARIO}` closed loop, {loop['seconds']:g} s (the master, CVODE over each T)",
             f"{loop['max_phi_gap']:.1e} rad (largest over the run)",
             f"{number(loop['mse_exchange'][0])} / {number(loop['mse_exchange'][1])} against "
             f"{number(loop['mse_rk4'][0])} / {number(loop['mse_rk4'][1])} (relative {rel[0]:.0e} / {rel[1]:.0e})"]]
    return (table(["run", "Model Exchange (CVODE, rtol " + f"{data['rel_tol']:g}) vs RK4 co-simulation arm",
                   "MSE joint 1 / 2"], rows)
            + f"\nMeasured by `python -m orchestration.bench.exchange` (stored in `{MEASUREMENT}`).\n")


def main(argv: list[str] | None = None) -> int:
    from orchestration.fmu_build.build import PACKAGE_ROOT
    from orchestration.paths import DEFAULT_FMU_DIR, fmu_folder

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu-dir", type=Path, default=fmu_folder(DEFAULT_FMU_DIR, 3))
    args = parser.parse_args(argv)
    doc = PACKAGE_ROOT / DOC_BLOCK[1]
    if not doc.is_file():
        parser.error(f"writes {MEASUREMENT} and {DOC_BLOCK[1]} of a source checkout; not found at {PACKAGE_ROOT}")
    data = measure(args.fmu_dir)
    atomic_write(PACKAGE_ROOT / MEASUREMENT, json.dumps(data, indent=1) + "\n")
    atomic_write(doc, replace_block(doc.read_text(), DOC_BLOCK[0], stored_block(PACKAGE_ROOT)))
    print(stored_block(PACKAGE_ROOT))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
