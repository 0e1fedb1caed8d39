"""Generated tables of docs/paper-notes.md on numerics (the fixed-order, CPU-independent cores): the CL stack's swap rule against the
earlier rule, whether its decisions rest on rounding, where the bound (5) holds chi_vd^a (whose derivative the core then sets to 0), and the learned W."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fmu_controller.saturation import ACCEL, LIMIT_HANDLINGS, RADIAL
from fmu_numerics.fixed_linalg import EPS
from fmu_controller.sotc_stack import SELECTIONS
from orchestration.markdown import stable, stable_pair, table
from orchestration.outputs import atomic_write
from orchestration.reports import perturbed
from orchestration.study import swap_margin
from orchestration.study.comparison import handling_code
from orchestration.study.sotc_study import setting_params, sotc_settings
from orchestration.study.tuning import tuned_parameters

RULES = ("maxeig", "maxeig-raw", "fill")


def _of(key: str, ns: list[dict[str, Any]]) -> list[Any]:
    return [n[key] for n in ns]


def cl_rule_table() -> str:
    """`paper` (100 s) under accel and radial with each swap rule: Table 1's metric, the swaps taken and
    lambda_min of the CL matrix at the end, each to the digits its perturbed runs share."""
    rows = []
    for code in (ACCEL, RADIAL):
        for rule in RULES:
            overrides = {"limit_handling": float(code), "cl_selection": float(SELECTIONS.index(rule))}
            m, ns = perturbed.metrics("paper", **overrides)
            s, ss = perturbed.sotc("paper", **overrides)
            rows.append([LIMIT_HANDLINGS[code], f"`{rule}`", stable_pair(m["mse"], _of("mse", ns)),
                         stable(m["tracking_cost"], _of("tracking_cost", ns)), stable(s["swaps"], _of("swaps", ss)),
                         stable(s["min_eig"], _of("min_eig", ss), ".2g")])
    return table(["limit handling", "cl_selection", "MSE j1 / j2", "realised cost", "swaps in 100 s",
                  "lambda_min(M) at 100 s"], rows)


FLIPS_STORE = "docs/swap-flips.json"


def _flip_rows() -> list[list[Any]]:
    """[label, limit handling, sorted parameters] of every case of the swap-flips table, in its order."""
    return [[label, code, sorted([k, v] for k, v in params.items())]
            for label, code, params in swap_margin.cases() + swap_margin.stress_cases()]


def write_flips(root: Path) -> int:
    """Count the offers, swaps and flips of every case under each of ``swap_margin.MARGINS`` (a 100 s run each)
    into ``root/FLIPS_STORE``; returns the number of cases."""
    rows = [[*row, [swap_margin.flip_counts(tuple(map(tuple, row[2])), m) for m in swap_margin.MARGINS]]
            for row in _flip_rows()]
    atomic_write(root / FLIPS_STORE, "[\n" + ",\n".join(json.dumps(r) for r in rows) + "\n]\n")  # a case a line
    return len(rows)


def stored_flips(root: Path) -> list[list[Any]]:
    """The stored counts, if their cases are this code's (else an error naming the command that rewrites them)."""
    rows = json.loads((root / FLIPS_STORE).read_text())
    if [r[:3] for r in rows] != _flip_rows():
        raise ValueError(f"{FLIPS_STORE} holds other cases than the code's: python -m {__name__}")
    return rows


def swap_flips_table(root: Path) -> str:
    """Every offer of a sample to the full CL stack re-decided with its thresholds moved by +-eps trace(M)
    (``orchestration.study.swap_margin``), for `paper` under each handling, every stored tuned SOTC design
    and the study's stress changes of radial `paper`, on the nominal 100 s `paper` loop: the offers, and the
    swaps and flips under each of ``swap_margin.MARGINS`` (counts of the one nominal run each, stored in
    ``FLIPS_STORE``; tests/unit/test_swap_margin.py recomputes them)."""
    rows = [[label, LIMIT_HANDLINGS[code], counts[0]["offers"], *(f"{c['swaps']} / {c['flips']}" for c in counts)]
            for label, code, _, counts in stored_flips(root)]
    names = ("margin", "a tenth of it", "the earlier tolerance")
    return table(["design", "limit handling", "offers to the full stack",
                  *(f"swaps / flips, {n} ({m / EPS:.0f} eps trace(M))" for n, m in zip(names, swap_margin.MARGINS))],
                 rows, "llrrrr")


def _bounded(setting: str, overrides: dict[str, float]) -> list[str]:
    s, ss = perturbed.sotc(setting, **overrides)
    last = stable(s["chi_a_last"], _of("chi_a_last", ss))
    return [stable(s["chi_a_bounded"], _of("chi_a_bounded", ss)), "-" if last == "-" else f"{last} s"]


def chi_a_bounded_table() -> str:
    """Samples (of 10,001) at which the bound (5) changes chi_vd^a, so that d(chi_vd^a)/dt = 0 there, for
    every shipped SOTC setting and the tuned SOTC designs."""
    rows = []
    for setting in sotc_settings():
        code = handling_code("SotcController", setting_params(setting))
        rows.append([f"`{setting}`", LIMIT_HANDLINGS[code], *_bounded(setting, {})])
    for code in (ACCEL, RADIAL, 1):
        rows.append(["tuned SOTC", LIMIT_HANDLINGS[code],
                     *_bounded("paper", {"limit_handling": float(code), **tuned_parameters("SotcController", code)})])
    return table(["design", "limit handling", "samples with chi_vd^a bounded", "last one"], rows)


def learned_w_table() -> str:
    """Section 3: W(100 s) of each CL / PE setting against the LQR value and the paper's W, each figure to
    the digits its perturbed runs share."""
    from fmu_controller.sotc import SotcCore
    from fmu_controller.sotc_math import weights_to_matrix
    from orchestration.study import ordered
    from orchestration.study.sotc_study import PAPER_W, lqr_weights

    ref = lqr_weights(1.39, SotcCore())
    norm = ordered.norm(ref)

    def figures(W: Any) -> dict[str, Any]:
        d = ordered.norm(np.asarray(W) - ref)
        return {"W": list(W), "d": d, "percent": 100 * d / norm,
                "eig": list(ordered.eigvalsh(weights_to_matrix(np.asarray(W))))}

    def row(label: str, W: Any, Ws: list[Any], min_eig: str) -> list[str]:
        f, fs = figures(W), [figures(w) for w in Ws]
        each = lambda key, spec: ", ".join(stable(v, [g[key][i] for g in fs], spec) for i, v in enumerate(f[key]))
        return [label, f"[{each('W', '.3g')}]",
                f"{stable(f['d'], _of('d', fs), '.3g')} ({stable(f['percent'], _of('percent', fs), '.3g')} %)",
                each("eig", ".2g"), min_eig]

    rows = []
    for setting in ("paper", "paper-long-pe", "paper-pe-only"):
        s, ss = perturbed.sotc(setting)
        min_eig = stable(s["min_eig"], _of("min_eig", ss), ".2g") if s["stack_count"] else "(no stack)"
        rows.append(row(f"`{setting}`", s["W"], _of("W", ss), min_eig))
    rows.append(row("the paper's W", PAPER_W, [], ""))
    return table(["setting", "W(100 s)", f"‖W - W_lqr‖ (‖W_lqr‖ = {norm:.3g})", "eig S(W)", "lambda_min(M)"], rows)


def main(argv: list[str] | None = None) -> int:
    """Rewrite ``FLIPS_STORE`` (69 runs of 100 s) in the checkout this module lies in."""
    import argparse

    argparse.ArgumentParser(prog=f"python -m {__name__}", description="Rewrite the swap-flips counts").parse_args(argv)
    print(f"{FLIPS_STORE}: {write_flips(Path(__file__).resolve().parents[2])} cases")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
