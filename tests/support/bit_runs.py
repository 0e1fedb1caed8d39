"""The runs whose bits must not depend on the CPU, as a child process of
``tests/orchestration/test_cpu_independence.py``:

    python tests/support/bit_runs.py FMU_DIR            # prints {case: {metric: float.hex()}} as JSON
    python tests/support/bit_runs.py FMU_DIR --write    # stores it as tests/data/reference_bits.json
    python tests/support/bit_runs.py --python           # the Python build's child: ``in_python_subset``

The cases: every shipped scenario's controller under every limit handling it accepts and every
controller's tuned design under every handling, GRID_TIME seconds in the pure loop (probing, the CL
stack filling and its first swaps); the SOTC's stored tuned designs (the first FAIR_SEEDS seeds, every handling) over the
whole experiment they are judged on, the fair evaluation's run (``orchestration.study.fair``: its
EVAL_STOP_TIME, at the first point of each held-out set); 100 s of ``paper`` and of its radial variant
through the FMUs of FMU_DIR (its build decides whether their cores are compiled). The pure loop runs
whatever ``fmu_controller`` this interpreter imports (the installed, compiled package, or the source
tree's ``.py`` with PYTHONPATH set to it).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from fmu_controller.saturation import ACCEL

DATA = Path(__file__).resolve().parents[1] / "data"
GRID_TIME = 2.0  # s of each grid run
FAIR_SEEDS = 1  # the fair runs of the first tuning seed's designs: each case adds its Python-build time under every
# environment of the CPU-independence test, and the arithmetic they run is the same whatever the seed
RADIAL = 0.0  # the limit_handling code of radial (fmu_controller.saturation.RADIAL)
# the Python build's children run the fair cases under accel only (the verdict's handling): a fair case is a 20 s
# SOTC run, half a Python child's time at every handling; each handling's own code (the saturation, its
# projection) runs in the pure-loop cases, every one under every handling, in both builds
PYTHON_FAIR_HANDLING = ACCEL


def in_python_subset(case: str) -> bool:
    """Whether the Python build's children run ``case``: no FMU case, the fair ones under ``PYTHON_FAIR_HANDLING``."""
    return not case.startswith("fmu ") and (not case.startswith("fair ") or f" handling {PYTHON_FAIR_HANDLING} " in case)


def _hex_leaves(metrics: dict) -> dict[str, str]:
    from support.reference_runs import flatten

    return {k: v.hex() for k, v in flatten(metrics).items()}


def _handlings(fmu: str) -> range:
    from fmu_controller.catalog import CORES

    spec = {s.name: s for s in CORES[fmu].PARAMETER_SPECS}["limit_handling"]
    return range(int(spec.low), int(spec.high) + 1)


def pure_loop_cases() -> dict[str, dict[str, str]]:
    from fmu_controller.catalog import CORES
    from orchestration.run.scenario import available_scenarios
    from orchestration.study.comparison import controller_of, run_metrics, tuned_metrics

    out = {}
    for name in available_scenarios():
        for code in _handlings(controller_of(name)[0]):
            out[f"loop {name} handling {code}"] = _hex_leaves(run_metrics(name, GRID_TIME, limit_handling=float(code)))
    for fmu in CORES:
        for code in (0, 1, 2):
            out[f"loop tuned {fmu} handling {code}"] = _hex_leaves(tuned_metrics(fmu, code, GRID_TIME)[1])
    return out


def fair_cases(handlings: tuple[int, ...] | None = None) -> dict[str, dict[str, str]]:
    from orchestration.study import fair
    from orchestration.study.tuning import HANDLINGS, stored

    checked = {fair.tuned_label("SotcController", s) for s in stored()["seeds"][:FAIR_SEEDS]}
    out = {}
    for handling in HANDLINGS if handlings is None else handlings:
        for label, (fmu, params) in fair.configurations(handling, ("SotcController",)).items():
            if label not in checked:
                continue
            for which in fair.SETS:
                m = fair.run_point(fmu, params, fair.evaluation_points(which)[0])
                out[f"fair {label} handling {handling} {which} point 0"] = {
                    k: "failed" if v is None else v.hex() for k, v in m.items()}
    return out


def fmu_cases(fmu_dir: Path) -> dict[str, dict[str, str]]:
    from support.reference_runs import comparable_summary

    from orchestration.run.master import run
    from orchestration.run.scenario import load_scenario
    from orchestration.run.summary import summarize

    paths = {p.stem: p for p in fmu_dir.glob("*.fmu")}
    out = {}
    for label, overrides in (("fmu paper 100 s", {}), ("fmu paper radial 100 s", {"controller.limit_handling": RADIAL})):
        scenario = load_scenario("paper").with_parameters(overrides)  # 100 s, its stop time
        result = run(scenario, paths)
        if result.failed:
            raise SystemExit(f"{label}: {result.error}")
        out[label] = _hex_leaves(comparable_summary(summarize(result)))
    return out


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/, for support.*
    if argv[0] == "--python":
        cases = {**pure_loop_cases(), **fair_cases((PYTHON_FAIR_HANDLING,))}
    else:
        cases = {**pure_loop_cases(), **fair_cases(), **fmu_cases(Path(argv[0]))}
    text = json.dumps(cases, indent=0, sort_keys=True)
    if argv[1:] == ["--write"]:
        (DATA / "reference_bits.json").write_text(text + "\n")
    else:
        print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
