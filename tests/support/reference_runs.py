"""Write the stored reference runs that ``tests/test_reference_runs.py`` compares against.

    python tests/support/reference_runs.py            # from the repository root, project installed

Runs every shipped scenario through the FMUs (no recording) and writes, under ``tests/data/``:

- ``reference_summaries.json``: each scenario's summary (``orchestration.run.summary.summarize``)
  without its wall time;
- ``reference_paper.npz``: every output of every instance of the ``paper`` run at every
  ``DECIMATE``-th sample and at the last one, keyed ``instance.variable``, plus ``time``.

The committed files come from main before the speed work (first 20eb717; then, for the scenarios
and summary keys added since, main at ff2e239, run as
``PYTHONPATH=<checkout of main> python tests/support/reference_runs.py``), so that test shows the
optimised code computes the same numbers (to 1e-12 relative). Regenerate them only when the maths
is meant to change, and say so in the commit.

    python tests/support/reference_runs.py --sensitivity

writes ``reference_sensitivity.json`` instead: for every scenario, how far each summary number moves
(relative, the largest of three) when one of the plant's initial angles moves by one ulp, so
rounding-sized. Other BLAS
kernels (another CPU, another numpy) round differently in every step, and a scenario that amplifies
rounding (``paper-literal`` and ``paper-long-pe`` move by up to 100 % and 200 %) cannot be held to
1e-12 there: ``test_reference_runs`` allows each number ten times its own measured sensitivity, and
1e-12 wherever that is smaller (every number of ``paper`` but the smallest CL-stack eigenvalue).
"""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1] / "data"
DECIMATE = 25  # 401 of the 10,001 samples of a 100 s run (and the last)


def reference_indices(samples: int) -> np.ndarray:
    return np.unique(np.r_[np.arange(0, samples, DECIMATE), samples - 1])


def comparable_summary(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k != "wall_time_s"}


def flatten(value, where: str = "") -> dict[str, float]:
    """Every float leaf of a summary, keyed by its path (``mse[0]``, ``final_weights[3]``)."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in flatten(item, f"{where}.{key}".lstrip(".")).items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in flatten(item, f"{where}[{i}]").items()}
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    return {where: float(value)} if number else {}


def _output_change(a: np.ndarray, b: np.ndarray) -> float:
    scale = float(np.max(np.abs(a))) if len(a) else 0.0
    return float(np.max(np.abs(a - b))) / scale if scale > 0.0 else 0.0


NUDGES = (("phi1_0", np.inf), ("phi1_0", -np.inf), ("phi2_0", np.inf))  # one ulp each way


def _sensitivity(paths: dict) -> dict[str, dict[str, float]]:
    from orchestration.run.master import run
    from orchestration.run.scenario import available_scenarios, load_scenario
    from orchestration.run.summary import summarize

    out: dict[str, dict[str, float]] = {}
    for name in available_scenarios():
        scenario = load_scenario(name)
        base = run(scenario, paths)
        a = flatten(comparable_summary(summarize(base)))
        worst: dict[str, float] = {}
        for param, direction in NUDGES:
            value = float(scenario.instances["plant"].parameters.get(param, 0.0))
            nudged = run(scenario.with_parameters({f"plant.{param}": float(np.nextafter(value, direction))}), paths)
            b = flatten(comparable_summary(summarize(nudged)))
            for k in a:
                if a[k] != 0.0:
                    worst[k] = max(worst.get(k, 0.0), abs(a[k] - b[k]) / abs(a[k]))
            if name == "paper":  # the stored outputs: each one's change relative to its largest value
                idx = reference_indices(base.samples)
                for inst, outs in base.outputs.items():
                    for var, series in outs.items():
                        key, change = f"{inst}.{var}", _output_change(series[idx], nudged.outputs[inst][var][idx])
                        out.setdefault("paper outputs", {})[key] = max(out.get("paper outputs", {}).get(key, 0.0), change)
        out[name] = {k: v for k, v in sorted(worst.items()) if v > 1e-13}
        print(name, "sensitivity", max(worst.values(), default=0.0), file=sys.stderr)
    return {name: {k: float(f"{v:.3g}") for k, v in leaves.items()} for name, leaves in out.items()}


def main(argv: list[str]) -> int:
    from orchestration.fmu_build.build import FMU_SOURCES, ensure_built
    from orchestration.run.master import run
    from orchestration.run.scenario import available_scenarios, load_scenario
    from orchestration.run.summary import summarize

    DATA.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="sotc_ref_") as tmp:
        paths = ensure_built(list(FMU_SOURCES), Path(tmp))
        if argv == ["--sensitivity"]:
            text = json.dumps(_sensitivity(paths), indent=1, allow_nan=False)
            (DATA / "reference_sensitivity.json").write_text(text + "\n")
            return 0
        summaries = {}
        for name in available_scenarios():
            result = run(load_scenario(name), paths)
            if result.failed:
                raise SystemExit(f"{name}: {result.error}")
            summaries[name] = comparable_summary(summarize(result))
            if name == "paper":
                idx = reference_indices(result.samples)
                arrays = {"time": result.time[idx]}
                for inst, outs in result.outputs.items():
                    arrays.update({f"{inst}.{v}": a[idx] for v, a in outs.items()})
                np.savez_compressed(DATA / "reference_paper.npz", **arrays)
            print(name, "ok", file=sys.stderr)
    (DATA / "reference_summaries.json").write_text(json.dumps(summaries, indent=1, allow_nan=False) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
