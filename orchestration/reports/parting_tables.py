"""Which decision parts the nearby runs of the SOTC designs that jump on the ladder (``ladder_tables``), stored
in ``STORE`` and printed in docs/robustness.md (``orchestration.study.parting``).

    python -m orchestration.reports.parting_tables     # every SOTC design that jumps under the verdict's handling
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.markdown import number, table
from orchestration.outputs import atomic_write
from orchestration.reports import perturbed
from orchestration.reports.fair_tables import VERDICT_HANDLING
from orchestration.reports.ladder_tables import JUMP, moves, relative_moves
from orchestration.study import fair
from orchestration.study.comparison import LADDER_DIRECTIONS, LADDER_SIZES
from orchestration.study.parting import APART, GROWTH, SHIFTS, SOLVE, STOP_TIME, parting

STORE = "docs/parting.json"


def pairs() -> dict[str, tuple[dict[str, float], int, float]]:
    """label -> (parameters, perturbation index, move) of every SOTC design of the fair comparison under the
    verdict's handling whose metric jumps on the ladder: of the smallest size that moves it by more than
    ``JUMP``, the direction that moves it most."""
    out = {}
    for label, (fmu, params) in fair.configurations(LIMIT_HANDLINGS.index(VERDICT_HANDLING)).items():
        nominal, others = perturbed.design(fmu, params, STOP_TIME, check=False)
        rung = next((k for k, m in enumerate(moves(nominal, others)) if m > JUMP), None)
        if fmu != "SotcController" or rung is None:
            continue
        rel = relative_moves(nominal, others)
        index = max(range(rung * LADDER_DIRECTIONS, (rung + 1) * LADDER_DIRECTIONS), key=rel.__getitem__)
        out[label] = (params, index, rel[index])
    return out


def write(root: Path) -> int:
    """Store the parting of every pair of ``pairs`` in ``root/STORE``; returns their number."""
    runs = {label: {"params": sorted([k, v] for k, v in params.items()), "move": move, **parting(params, index)}
            for label, (params, index, move) in pairs().items()}
    atomic_write(root / STORE, json.dumps(runs, indent=1, sort_keys=True) + "\n")
    return len(runs)


def stored(root: Path) -> dict[str, Any]:
    return json.loads((root / STORE).read_text())


def _decided(d: dict[str, Any] | None) -> list[str]:
    if d is None:
        return ["none logged", "-", "-", "-"]
    if d["what"] == SOLVE:
        moved, torque, inputs = d["moves"]
        return [f"the {SOLVE} of z_v takes another branch", f"{d['t']:g} s", "-",
                f"z_v moves {moved:.2g} rad/s and tau {torque:.2g} N.m for {inputs:.2g} of state and W"]
    if d["what"] != "CL stack swap":
        margins = " / ".join(f"{m:.2g}" for m in d["margins"]) if "margins" in d else "not logged"
        return [f"`{d['what']}` differs", f"{d['t']:g} s", "-", margins]
    rows = " / ".join("keeps its rows" if r < 0 else f"swaps row {r}" for r in d["rows"])
    margins = " / ".join(f"none up to {SHIFTS[-1]:g}" if m is None else f"{m:g}" for m in d["margins"])
    return ["CL stack swap", f"{d['t']:g} s", rows, margins]


def table_of(root: Path) -> str:
    """The stored pairs: the perturbation, how far the metric moves, where the difference jumps and the runs part,
    and the decision that turned it."""
    rows = []
    for label, r in stored(root).items():
        size = LADDER_SIZES[r["perturbation"] // LADDER_DIRECTIONS]
        jump, apart = ("never" if r[k] is None else f"{r[k]:g} s" for k in ("jump_t", "apart_t"))
        rows.append([label, f"{size:g} (direction {r['perturbation'] % LADDER_DIRECTIONS})",
                     f"{number(100 * r['move'], '.2g')} %", jump, apart,
                     *(f"{v:.2g} at {at:g} s" for v, at in (r["step_growth"], r["solve_gain"])),
                     *_decided(r["decided_by"])])
    header = [f"design ({VERDICT_HANDLING})", "perturbation", "move of MSE_1 + MSE_2",
              f"difference over {GROWTH:g} x the initial one at", f"angles apart by {APART:g} rad at",
              "largest growth of the difference in one sample, up to then",
              "largest move of the solve's z_v / the move of what it is solved from, up to then",
              "last decision that differs before it", "at", "nominal / perturbed run",
              "margin, nominal / perturbed (a swap: threshold shift / trace(M); the actuator limit: (torque - rho) / rho)"
              "; how far the solve's z_v moved"]
    return table(header, rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orchestration.reports.parting_tables", description=__doc__.splitlines()[0])
    ap.parse_args(argv)
    root = Path(__file__).resolve().parents[2]
    perturbed.use(root)
    print(f"{STORE}: {write(root)} pairs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
