"""Write the stored reference runs that ``tests/orchestration/test_reference_runs.py`` compares against.

    python tests/support/reference_runs.py            # from the repository root, project installed

Runs every shipped scenario through the FMUs (no recording) and writes, under ``tests/data/``:

- ``reference_summaries.json``: each scenario's summary (``orchestration.run.summary.summarize``)
  without its wall time;
- ``reference_paper.npz``: every output of every instance of the ``paper`` run at every
  ``DECIMATE``-th sample and at the last one, keyed ``instance.variable``, plus ``time``.

Regenerate them only when the numbers are meant to change (the maths, or as with the fixed-order arithmetic the order of
the cores' arithmetic), and say so in the commit. ``tests/support/bit_runs.py --write`` stores the runs
that ``test_cpu_independence`` checks under several CPU kernels.
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


def main(argv: list[str]) -> int:
    from orchestration.fmu_build.build import FMU_SOURCES, ensure_built
    from orchestration.run.master import run
    from orchestration.run.scenario import available_scenarios, load_scenario
    from orchestration.run.summary import summarize

    DATA.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="sotc_ref_") as tmp:
        paths = ensure_built(list(FMU_SOURCES), Path(tmp))
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
