"""Generated tables of docs/paper-notes.md on numerics (the fixed-order, CPU-independent cores): the CL stack's swap rule against the
earlier rule, and where the bound (5) holds chi_vd^a (whose derivative the core then sets to 0)."""
from __future__ import annotations

from fmu_controller.saturation import ACCEL, LIMIT_HANDLINGS, RADIAL
from fmu_controller.sotc_stack import SELECTIONS
from orchestration.markdown import stable, stable_pair, table
from orchestration.study.comparison import handling_code, run_perturbed
from orchestration.study.sotc_study import run, setting_params, sotc_settings
from orchestration.study.tuning import tuned_parameters

RULES = ("maxeig", "maxeig-raw", "fill")


def cl_rule_table() -> str:
    """`paper` (100 s) under accel and radial with each swap rule: Table 1's metric, the swaps taken and
    lambda_min of the CL matrix at the end."""
    rows = []
    for code in (ACCEL, RADIAL):
        for rule in RULES:
            overrides = {"limit_handling": float(code), "cl_selection": float(SELECTIONS.index(rule))}
            m, ns = run_perturbed("paper", **overrides)
            ctrl, _ = run("paper", **overrides)
            rows.append([LIMIT_HANDLINGS[code], f"`{rule}`", stable_pair(m["mse"], [n["mse"] for n in ns]),
                         stable(m["tracking_cost"], [n["tracking_cost"] for n in ns]), str(ctrl.stack.swaps),
                         f"{ctrl.stack.min_eig_at(list(ctrl.W)):.2g}"])
    return table(["limit handling", "cl_selection", "MSE j1 / j2", "realised cost", "swaps in 100 s",
                  "lambda_min(M) at 100 s"], rows)


def _bounded(setting: str, overrides: dict[str, float]) -> list[str]:
    _, res = run(setting, **overrides)
    flags = res.outputs[:, res.names.index("chi_a_bounded")] > 0.5
    active = res.t[flags]
    return [str(int(flags.sum())), f"{active[-1]:.2f} s" if len(active) else "-"]


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
