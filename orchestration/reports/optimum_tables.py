"""The optimum's tables, verdict sentence and figure, from a stored ``sotc-cosim optimum --json`` result.

The doc blocks read ``STORE`` (written by ``sotc-cosim optimum --json docs/optimum/optimum.json``, the
paper's state and the value study's 16 over 20 s), so tests/docs/test_docgen.py checks them in the
ordinary suite; tests/docs/test_optimum_store.py replays the stored optimal torques and re-runs a
controller to hold the stored numbers to the code. ``python -m orchestration.reports.optimum_tables``
draws ``FIGURE`` from the stored result.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from orchestration.markdown import number, table
from orchestration.reports.fair_tables import _cell
from orchestration.study.optimum import Problem, replay, trajectory_cost
from orchestration.study.optimum_scores import fair_core, ratios, run_controller
from orchestration.study.statistics import Interval

STORE = Path("docs") / "optimum" / "optimum.json"
STORE_B = STORE.with_name("optimum-b.json")  # objective B (``--objective B --cold paper``)
FIGURE = STORE.with_name("paper_state.png")
FIGURE_SPAN = 6.0  # s shown
AT_BOUND = 1e-6  # relative: a torque norm this close to rho is at the bound
LEARNED = "SOTC nominal"  # the paper's SOTC, learning as it runs: the figure's "learned" controller


def stored(root: Path, store: Path = STORE) -> dict[str, Any]:
    return json.loads((root / store).read_text())


def _interval(s: dict[str, Any]) -> Interval:
    return Interval(s["gmean"], s["low"], s["high"], s["n"], s["failed"])


def summary_table(data: dict[str, Any]) -> str:
    """Per controller: J / J* at the paper's state and over all states (geometric mean [95 % interval],
    range), lowest geometric mean first."""
    n = len(data["states"])
    rows = [[label, number(s["paper"], ".3f"), _cell(_interval(s)),
             f"{number(s['min'], '.3f')} - {number(s['max'], '.3f')}"]
            for label, s in sorted(data["summary"].items(), key=lambda kv: kv[1]["gmean"])]
    return table(["controller", "J / J*, paper's state", f"J / J*, {n} states: geometric mean [95 %]", "range"],
                 rows, "lrrr")


def states_table(data: dict[str, Any]) -> str:
    """Per initial state: J*, the solver's account, where it started, and the cold start's check."""
    rows = []
    for s in data["states"]:
        cold = s.get("cold")
        rows.append([str(s["index"]), ", ".join(f"{v:.3f}" for v in (*s["phi0"], *s["dphi0"])), f"{s['J_star']:.5g}",
                     f"{s['solver']['iterations']}", f"{s['solver']['seconds']:.1f}", s["warm_start"],
                     "-" if cold is None else f"{cold['relative_difference']:.1e} ({cold['iterations']} it.)"])
    return table(["state", "phi(0), dphi(0)", "J*", "IPOPT iterations", "solve [s]", "warm start from",
                  "cold start: J* relative difference"], rows, "llrrrlr")


def ratios_table(data: dict[str, Any]) -> str:
    """J / J* of every controller at every state (rows in the summary's order)."""
    order = sorted(data["summary"], key=lambda k: data["summary"][k]["gmean"])
    rows = [[label, *(number(r, ".3g") for r in ratios(data["states"], label))] for label in order]
    return table(["controller", *(str(s["index"]) for s in data["states"])], rows, "l" + "r" * len(data["states"]))


def report(data: dict[str, Any]) -> str:
    """The doc block: the problem in one line, both tables."""
    return "\n".join([
        f"Objective {data['objective']}, horizon {data['horizon']:g} s, every controller under the "
        f"`{data['handling']}` limit handling, ||tau|| <= {data['torque_limit']:g} N.m:", "",
        summary_table(data), "", "J / J* at each initial state (0: the paper's):", "", ratios_table(data), "",
        "Each state's J*, how the solver got there, and the cold start's check:", "", states_table(data)])


def paper_runs(data: dict[str, Any]) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """(problem, state record, {"optimum": its torques replayed, LEARNED: a fresh run}) at the paper's state."""
    state = next(s for s in data["states"] if s["index"] == 0)
    problem = Problem(tuple(state["phi0"]), tuple(state["dphi0"]), data["horizon"], data["objective"])
    return problem, state, {"optimum": replay(problem, np.array(state["torques"])),
                            LEARNED: run_controller(problem, fair_core(LEARNED))}


def gap_text(data: dict[str, Any]) -> str:
    """Where the learned SOTC's gap arises at the paper's state: while the optimum holds the torque at the
    bound from t = 0, the torque the SOTC applies, and the share of its excess cost J - J* incurred by then."""
    problem, state, runs = paper_runs(data)
    norms = {k: np.hypot(*r.tau[:problem.steps].T) for k, r in runs.items()}
    # the first sample off the bound (IPOPT's interior point stays within ~1e-8 of an active bound)
    k = int(np.argmax(norms["optimum"] < data["torque_limit"] * (1 - AT_BOUND)))
    until = float(runs["optimum"].t[k])
    excess = [trajectory_cost(problem, runs[LEARNED], t) - trajectory_cost(problem, runs["optimum"], t)
              for t in (until, 2 * until)]
    total = state["J"][LEARNED] - state["J_star"]
    return (f"over the first {until:.2f} s the optimum holds ||tau|| = rho = {data['torque_limit']:g} N.m (to "
            f"{AT_BOUND:g}) while the SOTC applies "
            f"{norms[LEARNED][:k].mean():.2f} N.m on average (at most {norms[LEARNED][:k].max():.2f}), and "
            f"{100 * excess[0] / total:.0f} % of its excess cost J - J* arises in that time "
            f"({100 * excess[1] / total:.0f} % by {2 * until:.2f} s)")


def verdict(data: dict[str, Any]) -> str:
    """One sentence for docs/optimum.md ("The verdict"): how far the learned SOTC and the best controller are from the optimum,
    and where the learned SOTC's gap arises from the paper's state."""
    summ = data["summary"]
    best = min(summ, key=lambda k: summ[k]["gmean"])
    learned = summ[LEARNED]
    return (f"Against the optimal torque sequence under the same bound (`sotc-cosim optimum`, objective "
            f"{data['objective']}, {data['horizon']:g} s from {len(data['states'])} initial states, "
            f"`docs/optimum.md`), the SOTC as the paper runs it costs {_cell(_interval(learned))} times the "
            f"optimum (geometric mean [95 %]; the lowest, {best}, {_cell(_interval(summ[best]))}); from the paper's "
            f"state ({number(learned['paper'], '.3f')} x J*) {gap_text(data)}.")


def figure(data: dict[str, Any], path: Path) -> Path:
    """The optimal and the learned SOTC's torque norm and errors from the paper's initial state."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    _, state, runs = paper_runs(data)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for label, run in runs.items():
        label = label if label == "optimum" else f"{label} (learning as it runs)"
        axes[0].plot(run.t, np.hypot(run.tau[:, 0], run.tau[:, 1]), label=label)
        axes[1].plot(run.t, run.error[:, 0], label=label)
        axes[2].plot(run.t, run.error[:, 1], label=label)
    axes[0].axhline(data["torque_limit"], color="k", lw=0.8, ls="--", label="rho")
    for ax, name in zip(axes, ("||tau|| [N.m]", "e1 [rad]", "e2 [rad]")):
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right")
    axes[2].set_xlabel(f"t [s] (the first {FIGURE_SPAN:g} s of {data['horizon']:g}: the rest of the runs coincide)")
    axes[2].set_xlim(0.0, FIGURE_SPAN)
    axes[0].set_title(f"Paper's initial state: J* = {state['J_star']:.4g}, "
                      f"{LEARNED} J = {state['J'][LEARNED]:.4g}")
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.part.png")
    fig.savefig(tmp, dpi=80)
    plt.close(fig)
    tmp.replace(path)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2], help="the source checkout")
    args = ap.parse_args(argv)
    print(figure(stored(args.root), args.root / FIGURE))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
