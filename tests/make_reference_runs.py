"""Write the stored reference runs that ``tests/test_reference_runs.py`` compares against.

    python tests/make_reference_runs.py            # from the repository root, project installed

Runs every shipped scenario through the FMUs (no recording) and writes, under ``tests/data/``:

- ``reference_summaries.json``: each scenario's summary (``orchestration.summary.summarize``)
  without its wall time;
- ``reference_paper.npz``: every output of every instance of the ``paper`` run at every
  ``DECIMATE``-th sample and at the last one, keyed ``instance.variable``, plus ``time``.

The committed files come from main without the speed work of issue 13 (first 20eb717; then, for
the scenarios and summary keys that issues 9-12 added, main at ff2e239, run as
``PYTHONPATH=<checkout of main> python tests/make_reference_runs.py``), so that test shows the
optimised code computes the same numbers (to 1e-12 relative). Regenerate them only when the maths
is meant to change, and say so in the commit.
"""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data"
DECIMATE = 25  # 401 of the 10,001 samples of a 100 s run (and the last)


def reference_indices(samples: int) -> np.ndarray:
    return np.unique(np.r_[np.arange(0, samples, DECIMATE), samples - 1])


def comparable_summary(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k != "wall_time_s"}


def main() -> int:
    from orchestration.build import FMU_SOURCES, ensure_built
    from orchestration.master import run
    from orchestration.scenario import available_scenarios, load_scenario
    from orchestration.summary import summarize

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
    raise SystemExit(main())
