"""Every table of measured numbers in README.md and docs/ is written by this module.

    python -m orchestration.reports.docgen write [NAME ...]    # regenerate the marked blocks (default: all)
                                                               # and the perturbed runs they print
    python -m orchestration.reports.docgen check [NAME ...]    # exit 1 and list the blocks that differ
    python -m orchestration.reports.docgen list

A block is the text between ``<!-- BEGIN generated:NAME -->`` and ``<!-- END generated:NAME -->`` in
its file; the generator below produces it from pure-loop runs (``orchestration.study.comparison``,
``orchestration.study.sotc_study``, ``orchestration.study.value_function``), which the FMU runs equal sample for
sample. tests/docs/test_docgen.py fails when a committed block differs from what the code produces (the
quick blocks in the ordinary suite, the long ones under the ``slow`` marker).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write
from orchestration.bench.speed import DOC_BLOCKS as SPEED_BLOCKS
from orchestration.bench.speed import MEASUREMENT as SPEED_MEASUREMENT
from orchestration.bench.speed import stored_block
from orchestration.bench.targets import check_targets
from orchestration.bench import exchange
from orchestration.markdown import block_pattern, number, replace_block, stable, stable_pair, table
from orchestration.reports import (fair_tables, heldout_tables, ladder_tables, numerics_tables, optimum_tables, parting_tables,
                                   perturbed, training_tables)
from orchestration.study.comparison import (
    COMPARED,
    OTC_VARIANTS,
    PAPER_TABLE1,
    TABLE1_MARGIN,
    chaos_of,
    controller_of,
    handling_name,
    mse_sum,
    within_table1,
)
from orchestration.study import tuning
from orchestration.study.tuning import CONTROLLERS, NOMINAL_SCENARIO
from orchestration.study.statistics import level, paired
from orchestration.study.sotc_study import NO_LEARNING
from orchestration.sweep.results import (
    paired_tail_errors,
    stored_rows,
    stored_sweep_block,
)

ROOT = Path(__file__).resolve().parents[2]
LITERAL_SCENARIOS = ("paper-literal", "paper-near-literal")


METRIC_HEADER = ["MSE j1 / j2", "MSE t >= 5 s", "MSE after last limit sample (t)", "realised cost",
                 "samples over 4 N.m", "max ‖tau‖"]


def metric_cells(m: dict[str, Any], ns: list[dict[str, Any]]) -> list[str]:
    """Table cells of the metrics m of a run, each figure to the digits it shares with the metrics in ns of
    the same run under every perturbation of the initial state (``perturbed.metrics``)."""
    def of(key: str) -> list[Any]:
        return [n[key] for n in ns]

    last = m["last_limit_time"]
    when = "limit never acts" if last is None else stable(last, of("last_limit_time"), ".3g") + " s"
    after = f"{stable_pair(m['mse_after_limit'], of('mse_after_limit'), '.3g')} ({when})"
    return [stable_pair(m["mse"], of("mse")), stable_pair(m["mse_after_5s"], of("mse_after_5s"), ".3g"), after,
            stable(m["tracking_cost"], of("tracking_cost")), stable(m["samples_over_limit"], of("samples_over_limit")),
            stable(m["max_tau_norm"], of("max_tau_norm"))]


# --- the blocks -------------------------------------------------------------------------------------

def _params_text(scenario: str, overrides: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:g}" for k, v in overrides.items()) or "defaults"


def handlings_table() -> str:
    """Every controller under every limit handling (scenario defaults otherwise)."""
    rows = []
    for scenario, codes in COMPARED:
        fmu, _ = controller_of(scenario)
        for code in codes:
            rows.append([LABELS[fmu], f"`{scenario}`", handling_name(scenario, limit_handling=code),
                         *metric_cells(*perturbed.metrics(scenario, limit_handling=code))])
    return table(["controller", "scenario", "limit handling", *METRIC_HEADER], rows)


def reading_cells(scenario: str, **overrides: float) -> list[str]:
    """``metric_cells`` of an SOTC reading, or, for a chaotic one (Table 1's metric moves by more than
    ``CHAOS_THRESHOLD`` under a perturbation of the initial state), what is reproducible about it
    (``comparison.chaos_of``)."""
    m, ns = perturbed.metrics(scenario, **overrides)
    cells = metric_cells(m, ns)
    chaos = chaos_of(m, ns)
    if chaos is not None:
        cells[:4] = [chaos, "-", "-", "-"]
    return cells


def results_table() -> str:
    """docs/results.md: the paper's Table 1, the SOTC readings, every controller per handling, and
    every controller tuned by the one protocol (``orchestration.study.tuning``)."""
    return table(*results_rows())


SUMMARY_COLUMNS = (0, 2, 3, 6, 8)  # controller / reading, limit handling, MSE j1 / j2, realised cost, max |tau|


def results_summary() -> str:
    """README's short table: the rows of ``results_table`` under the paper's Table 1 and the accel handling
    (the one every controller is tuned and judged under), fewer columns; the full table is docs/results.md."""
    header, rows = results_rows()
    keep = [r for r in rows if r[0].startswith("paper, Table 1") or (r[2] == "accel" and (
        r[0] == "SOTC, chosen reading" or ", tuned (" in r[0]))]
    return table([header[i] for i in SUMMARY_COLUMNS], [[r[i] for i in SUMMARY_COLUMNS] for r in keep])


def results_rows() -> tuple[list[str], list[list[str]]]:
    """The header and rows of ``results_table``."""
    rows = [[f"paper, Table 1: {k}", "", "(not stated)", f"{a} / {b}", "", "", "", "", ""]
            for k, (a, b) in PAPER_TABLE1.items()]
    for scenario in LITERAL_SCENARIOS:
        rows.append([f"SOTC, {scenario.removeprefix('paper-')} reading", f"`{scenario}`", handling_name(scenario),
                     *reading_cells(scenario)])
    for scenario, codes in COMPARED:
        fmu, _ = controller_of(scenario)
        sotc = fmu == "SotcController"
        label = "SOTC, chosen reading" if sotc else f"{LABELS[fmu]} (scenario defaults)"
        for code in codes:
            cells = reading_cells(scenario, limit_handling=code) if sotc else metric_cells(
                *perturbed.metrics(scenario, limit_handling=code))
            rows.append([label, f"`{scenario}`", handling_name(scenario, limit_handling=code), *cells])
    for fmu in CONTROLLERS:
        for code in (2, 0):
            design = tuning.best_design(fmu, code)
            rows.append([f"{LABELS[fmu]}, tuned (seed {tuning.stored()['seeds'][0]}: {fair_tables.design_text(design)})",
                         f"`{NOMINAL_SCENARIO[fmu]}`",
                         LIMIT_HANDLINGS[code], *metric_cells(*perturbed.tuned(fmu, code))])
    return ["controller / reading", "scenario", "limit handling", *METRIC_HEADER], rows


_ADDED = {"accel": ", a handling of the bound (5) the paper does not give"}


def _reading_label(scenario: str, overrides: dict[str, float]) -> str:
    h = handling_name(scenario, **overrides)
    learning = ", learning off (alpha1 = alpha2 = 1e-9)" if overrides.get("alpha1") == NO_LEARNING["alpha1"] else ""
    return f"`{scenario}` ({h}{_ADDED.get(h, '')}{learning})"


def mse(m: dict[str, Any], ns: list[dict[str, Any]]) -> str:
    return stable_pair(m["mse"], [n["mse"] for n in ns])


def cost(m: dict[str, Any], ns: list[dict[str, Any]]) -> str:
    return stable(m["tracking_cost"], [n["tracking_cost"] for n in ns])


def results_verdict() -> str:
    """The plain sentences under the results table (docs/results.md): which readings reach Table 1 and at what cost,
    whether the critic's learning is what reaches it, and whether a baseline given the SOTC's limit
    handling beats it."""
    paper = PAPER_TABLE1["SOTC"]
    sotc_codes = next(codes for scenario, codes in COMPARED if scenario == "paper")
    candidates = [(s, {}) for s in LITERAL_SCENARIOS] + [("paper", {"limit_handling": c}) for c in sotc_codes]
    candidates.append(("paper", dict(NO_LEARNING)))
    measured = [(s, o, *perturbed.metrics(s, **o)) for s, o in candidates]

    def text(s, o, m, n):
        chaos = chaos_of(m, n)
        if chaos is not None:
            return f"{_reading_label(s, o)}: {chaos}"
        return f"{_reading_label(s, o)}: MSE {mse(m, n)}, realised cost {cost(m, n)}"

    reach = [text(s, o, m, n) for s, o, m, n in measured if within_table1(m["mse"])]
    miss = [text(s, o, m, n) for s, o, m, n in measured if not within_table1(m["mse"])]
    chosen, chosen_n = perturbed.metrics("paper")
    learned_off, off_n = perturbed.metrics("paper", **NO_LEARNING)
    lines = [
        f"Within {100 * (TABLE1_MARGIN - 1):.0f} % of Table 1's {paper[0]} / {paper[1]}: {'; '.join(reach) or 'none'}. "
        f"Not within: {'; '.join(miss) or 'none'}.",
        f"The critic's learning is not what reaches Table 1: with it switched off, `paper` gives MSE "
        f"{mse(learned_off, off_n)} and realised cost {cost(learned_off, off_n)}, against "
        f"{mse(chosen, chosen_n)} and {cost(chosen, chosen_n)} with learning; the match rests on the "
        "feedforward (4) and how the bound (5) is handled."
        if within_table1(learned_off["mse"]) else
        f"Switching the critic's learning off (alpha1 = alpha2 = 1e-9) moves `paper` out of Table 1's range: "
        f"MSE {mse(learned_off, off_n)}, realised cost {cost(learned_off, off_n)}."]
    tuned = sorted(((fmu, *perturbed.tuned(fmu, 2)) for fmu in CONTROLLERS), key=lambda t: mse_sum(t[1]))
    lines.append("On the paper's nominal `paper` loop (100 s, not in the tuning's training set; accel for every "
                 "controller, each at the best design of the first tuning seed), Table 1's metric ranks them: " + "; ".join(
                     f"{LABELS[fmu]} {mse(m, n)} (cost {cost(m, n)})" for fmu, m, n in tuned)
                 + ". How they compare on points the tuning never saw, across the tuning seeds: the paired "
                 "statistics of docs/robustness.md ('Fair comparison').")
    return "\n".join(f"- {line}" for line in lines)


def nominal_tuned_table() -> str:
    """docs/baselines.md: every controller nominal and tuned (the SOTC also with learning off) under
    each handling, on the tuning run (the nominal 100 s `paper` loop)."""
    rows = []
    for code in (2, 0, 1):
        for fmu in CONTROLLERS:
            scenario = NOMINAL_SCENARIO[fmu]
            variants = [("nominal", {}), ("tuned", tuning.tuned_parameters(fmu, code))]
            if fmu == "SotcController":
                variants += [(f"{d}, learning off", {**ov, **NO_LEARNING}) for d, ov in variants]
            for what, overrides in variants:
                rows.append([LIMIT_HANDLINGS[code], LABELS[fmu], what,
                             *metric_cells(*perturbed.metrics(scenario, limit_handling=code, **overrides))])
    return table(["limit handling", "controller", "design", *METRIC_HEADER], rows)


def settings_table() -> str:
    from orchestration.study.sotc_study import sotc_settings

    rows = [[f"`{s}`", handling_name(s), *metric_cells(*perturbed.metrics(s))] for s in sotc_settings()]
    return table(["setting", "limit handling", *METRIC_HEADER], rows)


def readings_table() -> str:
    from orchestration.study.sotc_study import READINGS

    rows = [[label, _params_text("paper", ov), *metric_cells(*perturbed.metrics("paper", **ov))] for label, ov in READINGS]
    return table(["reading", "parameters", *METRIC_HEADER], rows)


def value_table() -> str:
    from orchestration.study.value_function import value_report

    nominal, others = perturbed.value("paper")
    return value_report(perturbed.value_rows_of(nominal), [perturbed.value_rows_of(o) for o in others])


def otc_table() -> str:
    rows = [[label, *metric_cells(*perturbed.metrics("paper-otc", **ov))] for label, ov in OTC_VARIANTS]
    return table(["OTC variant", *METRIC_HEADER], rows)


def controllers_verdict() -> str:
    """The plain sentences on the stored `controllers` sweep: each controller's post-transient error over
    the same perturbed points, lowest first, and whether a baseline beats the SOTC there."""
    sweep, rows = stored_rows("controllers", ROOT / "docs")
    errors = paired_tail_errors(rows)
    own = sweep.controller_parameters()
    handling = sweep.fixed.get("controller.limit_handling")

    def label(fmu: str) -> str:
        params = " or ".join(", ".join(f"{k.partition('.')[2]} {v:g}" for k, v in p.items()) for p in own.get(fmu, []))
        entry = sweep.per_controller.get(fmu)
        if entry is not None and not entry.learning:
            return f"{fmu} (the design of {LABELS.get(entry.fmu, entry.fmu)} above, critic frozen: alpha1 = alpha2 = 1e-9)"
        if entry is not None and entry.tuning == "best":
            how = f"best of its tuning search: {params}"
        elif params:
            how = params
        else:
            how = "the paper's tuning" if fmu == "SotcController" else "its defaults"
        return f"{LABELS.get(fmu, fmu)} ({how})"

    def stats(fmu: str) -> tuple[float, float, int]:
        ok = [e for e in errors[fmu].values() if e is not None]
        return (float(np.mean(ok)) if ok else float("inf"), max(ok, default=float("inf")), len(errors[fmu]) - len(ok))

    ranked = sorted(errors, key=lambda fmu: stats(fmu)[0])
    under = f" under `{LIMIT_HANDLINGS[int(handling)]}`" if handling is not None else ""  # set for every point
    lines = ["Post-transient error over the same points (mean / worst, rad; failed points apart), lowest mean "
             f"first{under and ', all' + under}: " + "; ".join(
                 f"{label(f)} {number(stats(f)[0], '.3g')} / {number(stats(f)[1], '.3g')}" + (f", {stats(f)[2]} failed" if stats(f)[2] else "")
                 for f in ranked) + "."]
    sotc = errors.get("SotcController")
    if sotc is not None:
        said = []
        family = len(ranked) - 1  # the verdicts of this sentence (Bonferroni, orchestration.study.statistics)
        for fmu in ranked:
            if fmu == "SotcController":
                continue
            keys = sorted(errors[fmu])
            v = paired([sotc.get(k) for k in keys], [errors[fmu][k] for k in keys], family)
            said.append(f"against {label(fmu)}: {v.said} (SOTC / it {number(v.ratio.value, '.3g')}, interval "
                        f"[{number(v.ratio.low, '.3g')}, {number(v.ratio.high, '.3g')}], worse on {v.worse_on} of "
                        f"{v.ratio.n} paired points)")
        lines.append("Tail (not tuned for: the criterion of every search is the MSE), this sweep's designs only (the "
                     "tuned ones from a single tuning seed): a description of these points, not a verdict of the comparison, "
                     "which judges every tuning seed in one family (\"The verdict\" below). "
                     "The SOTC, paired point by point (geometric mean of the ratio of post-transient errors; family: "
                     f"these {family} verdicts, each interval at {100 * level(family):.3g} %, Bonferroni), is "
                     + "; ".join(said) + ".")
    return "\n".join(f"- {line}" for line in lines)


@dataclass(frozen=True)
class Block:
    file: str
    make: Callable[[], str]
    slow: bool  # needs more than a few dozen 100 s runs (every figure is judged over 49: ``perturbed``)


def integrator_table() -> str:
    """docs/integration.md: the accuracy of RK4 with N substeps against DOP853 (timings: the bench)."""
    from orchestration.bench.design import integrator_errors

    errors = integrator_errors()
    rows = [[str(n), f"{q:.2e}", f"{w:.2e}", "-" if i == 0 else f"{errors[i - 1][1] / q:.1f}"]
            for i, (n, q, w) in enumerate(errors)]
    return table(["N substeps", "max abs phi error [rad]", "max abs dphi error [rad/s]", "phi error of N/2 over N"], rows)


BLOCKS: dict[str, Block] = {
    "integrator": Block("docs/integration.md", integrator_table, False),
    "results": Block("docs/results.md", results_table, True),
    "results-summary": Block("README.md", results_summary, True),
    "readme-verdict": Block("README.md", lambda: fair_tables.headline(ROOT), False),
    "results-verdict": Block("docs/results.md", results_verdict, True),
    "handlings": Block("docs/baselines.md", handlings_table, True),
    "tuning": Block("docs/baselines.md", fair_tables.tuning_table, False),
    "tuning-summary": Block("docs/baselines.md", fair_tables.tuning_summary, False),
    "training-size": Block("docs/baselines.md", lambda: training_tables.comparison(ROOT), False),
    "nominal-tuned": Block("docs/baselines.md", nominal_tuned_table, True),
    "fair-initial": Block("docs/robustness.md", lambda: fair_tables.summary_table(ROOT, "initial states"), False),
    "fair-perturbed": Block("docs/robustness.md", lambda: fair_tables.summary_table(ROOT, "perturbed"), False),
    "fair-paired": Block("docs/robustness-paired.md", lambda: fair_tables.paired_table(ROOT), False),  # the appendix
    "fair-verdict": Block("docs/robustness.md", lambda: fair_tables.verdict(ROOT), False),
    "ladder": Block("docs/robustness.md", ladder_tables.ladder_table, True),
    "ladder-tuning": Block("docs/robustness.md", ladder_tables.tuning_table, True),
    # the stored partings (rerun: python -m orchestration.reports.parting_tables)
    "parting": Block("docs/robustness.md", lambda: parting_tables.table_of(ROOT), False),
    # the stored held-out ladder (rerun: python -m orchestration.reports.heldout_tables)
    "heldout-ladder": Block("docs/robustness.md", lambda: heldout_tables.block(ROOT), False),
    # the stored optimum (rerun: sotc-cosim optimum --cold all --json docs/optimum/optimum.json)
    "optimum": Block("docs/optimum.md", lambda: optimum_tables.report(optimum_tables.stored(ROOT)), False),
    "optimum-verdict": Block("docs/optimum.md", lambda: optimum_tables.verdict(optimum_tables.stored(ROOT)), False),
    "optimum-b": Block("docs/optimum.md",
                       lambda: optimum_tables.report(optimum_tables.stored(ROOT, optimum_tables.STORE_B)), False),
    "otc-variants": Block("docs/baselines.md", otc_table, True),
    "settings": Block("docs/paper-notes.md", settings_table, True),
    "readings": Block("docs/paper-notes.md", readings_table, True),
    "value": Block("docs/paper-notes.md", value_table, True),
    "learned-w": Block("docs/paper-notes.md", numerics_tables.learned_w_table, True),
    "cl-rule": Block("docs/paper-notes.md", numerics_tables.cl_rule_table, True),
    # the stored counts (rerun: python -m orchestration.reports.numerics_tables)
    "swap-flips": Block("docs/paper-notes.md", lambda: numerics_tables.swap_flips_table(ROOT), False),
    "chi-a-bounded": Block("docs/paper-notes.md", numerics_tables.chi_a_bounded_table, True),
    # the results of a shipped sweep, from its stored rows (rerun: sotc-cosim sweep NAME --doc docs/robustness.md)
    "sweep-robustness": Block("docs/robustness.md", lambda: stored_sweep_block("robustness", ROOT / "docs"), False),
    "sweep-controllers": Block("docs/robustness.md", lambda: stored_sweep_block("controllers", ROOT / "docs"), False),
    "controllers-verdict": Block("docs/robustness.md", controllers_verdict, False),
    # the stored speed measurement (rerun: sotc-cosim bench --update-docs)
    "speed": Block("docs/performance.md", lambda: stored_block(ROOT), False),
    # the stored Model Exchange measurement (rerun: python -m orchestration.bench.exchange)
    "exchange": Block("docs/interop.md", lambda: exchange.stored_block(ROOT), False),
}


def committed(name: str, root: Path | None = None) -> str:
    """The block's text as it is in its file now (error if the markers are missing)."""
    text = ((root or ROOT) / BLOCKS[name].file).read_text()
    m = block_pattern(name).search(text)
    if m is None:
        raise KeyError(f"{BLOCKS[name].file} has no block 'generated:{name}'")
    return m.group(2)


def render(name: str) -> str:
    """The block as the code produces it now, its perturbed figures read from the store (``perturbed``)."""
    perturbed.use(ROOT)
    try:
        return BLOCKS[name].make().rstrip("\n") + "\n"
    except perturbed.Stale as exc:
        raise perturbed.Stale(f"stale: run python -m orchestration.reports.docgen write {name} ({exc})") from None


def store_perturbed(names: list[str], workers: int) -> None:
    """Compute and store the perturbed runs of the blocks ``names``: their tables are made once with the
    nominal runs to learn which configurations they print (the store keeps the others unless ``names`` is
    every block)."""
    perturbed.use(ROOT)
    with perturbed.collecting() as configurations:
        for n in names:
            if BLOCKS[n].slow:  # the quick blocks print no perturbed figure
                BLOCKS[n].make()
    if configurations:
        done = perturbed.compute(configurations, keep_others=set(names) != set(BLOCKS), workers=workers)
        print(f"{perturbed.STORE}: {len(configurations)} configurations, {done} perturbed runs", flush=True)


def write(name: str, root: Path | None = None) -> bool:
    """Regenerate one block in place; True if it changed."""
    path = (root or ROOT) / BLOCKS[name].file
    committed(name, root)
    content = render(name)  # first: the file is read (and rewritten) only once the block is computed
    text = path.read_text()
    new = replace_block(text, name, content)
    atomic_write(path, new)
    return new != text


def store_speed_measurement(data: dict, root: Path) -> list[Path]:
    """Store one ``sotc-cosim bench speed`` result as the measurement and regenerate its blocks."""
    atomic_write(root / SPEED_MEASUREMENT, json.dumps(data, indent=1) + "\n")
    for name in SPEED_BLOCKS:
        write(name, root)
    return [root / SPEED_MEASUREMENT, *(root / f for f in SPEED_BLOCKS.values())]


def store_speed_row(name: str, row: dict, root: Path) -> list[Path]:
    """Store one row of the speed bench measured alone (``sotc-cosim bench foreign``) into the stored measurement,
    its other figures kept (the row carries its own date), the targets judged again; regenerate its blocks."""
    data = json.loads((root / SPEED_MEASUREMENT).read_text())
    data[name] = row
    data["targets"] = check_targets(data)
    return store_speed_measurement(data, root)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("action", choices=("write", "check", "list"))
    ap.add_argument("names", nargs="*", metavar="NAME", help=f"blocks (default all: {', '.join(BLOCKS)})")
    ap.add_argument("--workers", type=int, default=2, metavar="N",
                    help="processes for the perturbed runs of write (default 2)")
    args = ap.parse_args(argv)
    if args.workers < 1:
        print(f"docgen: --workers must be at least 1, not {args.workers}", file=sys.stderr)
        return 2
    names = args.names or list(BLOCKS)
    unknown = [n for n in names if n not in BLOCKS]
    if unknown:
        print(f"docgen: no block {unknown}; known: {', '.join(BLOCKS)}", file=sys.stderr)
        return 2
    if args.action == "list":
        for n in names:
            print(f"{n:16s} {BLOCKS[n].file}{' (slow)' if BLOCKS[n].slow else ''}")
        return 0
    if args.action == "write":
        store_perturbed(names, args.workers)
    stale = []
    for n in names:
        if args.action == "write":
            print(f"{n}: {'rewritten' if write(n) else 'unchanged'}", flush=True)
            continue
        try:
            if render(n) != committed(n):
                stale.append(n)
        except perturbed.Stale as exc:
            print(exc)
            stale.append(n)
    if stale:
        print(f"stale blocks (run python -m orchestration.reports.docgen write {' '.join(stale)}): {', '.join(stale)}")
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
