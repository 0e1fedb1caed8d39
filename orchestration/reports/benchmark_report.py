"""The benchmark's report (``report.md`` in its output folder), every table generated from its store
(``orchestration.study.benchmark``) and the shipped reference (``orchestration.study.benchmark_reference``):

* the tuned design of each seed and whether its search converged by the protocol's rule;
* the held-out figures: geometric mean of each measure with its BCa interval, per set and seed, beside our
  tuned controllers' on the same points;
* paired verdicts against our tuned SOTC, CT, LQR and OTC, corrected together with the README's stored family
  (Bonferroni over both), stated as the README states its own: only what every draw and every seed gives,
  clear of the marginal band, on the measure the tuning judged (the tail judges what no search was tuned for);
* J / J* at the stored optimum's states; the samples the actuator cut; the runs that failed and why.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

from fmu_controller.catalog import LABELS
from orchestration.markdown import number, table
from orchestration.reports.fair_tables import NOT_TUNED_FOR, _agreed, _cell, _every, _seeds_cell
from orchestration.study import fair
from orchestration.study.benchmark_reference import load as reference
from orchestration.study.protocol import BUDGET, POLISH, SEEDS
from orchestration.study.statistics import PairedVerdict, geometric_interval, geometric_intervals, level, paired_verdicts
from orchestration.study.tuning import CONTROLLERS, CONVERGED, improvement, still_improving, tpe_improvement

OURS = tuple(LABELS[f] for f in CONTROLLERS)  # SOTC first: the one the benchmark is about
FAILED_ON = "not stated: A failed on"


def _measure(values: list, draw_index: int | None, n: int) -> list:
    return values if draw_index is None else values[draw_index * n:(draw_index + 1) * n]


def _ours(ref: dict, label: str, seed: str, which: str, name: str, draw_index: int | None, n: int) -> list:
    """Our tuned controller's stored runs on the first ``n`` points of each draw (all draws, or one)."""
    stored = ref["runs"][label][seed][which][name]
    full = ref["n_points"]
    per_draw = [stored[k * full:k * full + n] for k in range(len(ref["draws"]))]
    return [v for d in per_draw for v in d] if draw_index is None else per_draw[draw_index]


def family(store: dict, ref: dict) -> int:
    """The verdicts corrected together on one draw: the README's stored family and this benchmark's (each seed
    against each of our tuned controllers, per set and measure)."""
    return ref["family"] + len(fair.SETS) * len(OURS) * len(fair.MEASURES) * len(store["seeds"])


def _converged(r: dict, store: dict) -> str:
    """Converged only by the protocol's budget and rule: a smaller budget is "not converged" whatever it shows."""
    if r["trials"] < store["budget"] + store["polish"]:
        return "incomplete"
    if still_improving(r):
        return "still improving (not converged)"
    return "converged" if store["budget"] >= BUDGET and store["polish"] >= POLISH else "not converged (a smaller budget)"


def protocol_text(store: dict) -> str:
    """What ran, and where it is not the stored protocol."""
    off = []
    if store["budget"] < BUDGET or store["polish"] < POLISH:
        off.append(f"a budget of {store['budget']} TPE + {store['polish']} CMA-ES trials (the protocol: {BUDGET} + {POLISH})")
    if len(store["seeds"]) < len(SEEDS):
        off.append(f"{len(store['seeds'])} seed{'s' if len(store['seeds']) > 1 else ''} (the protocol: {len(SEEDS)})")
    if store["points"] < fair.N_POINTS:
        off.append(f"the first {store['points']} of the {fair.N_POINTS} held-out points of each draw")
    c = store["controller"]
    fixed = ", ".join(f"{k} = {v:g}" for k, v in c["fixed"].items()) or "nothing"
    head = [f"Controller file `{c['file']}`: `{c['fmu']}` (SHA-256 {c['fmu_sha256'][:16]}...), searched over "
            f"{', '.join(d['name'] for d in c['search'])}; fixed: {fixed}.",
            f"Seeds {', '.join(map(str, store['seeds']))}; {store['budget']} TPE then {store['polish']} CMA-ES trials per "
            f"seed, the training points and criterion of `sotc-cosim tune`; held out on {len(store['draws'])} draws of "
            f"{store['points']} point{'s' if store['points'] > 1 else ''} per set, {store['stop_time']:g} s each; torques "
            "bounded by the actuator (radial projection onto 4 N.m), ours under accel. Measures: mse = MSE_1 + MSE_2 over "
            "the run (eq. (50), rad^2, what the tuning judged); tail = max |e| over its last half (rad)."]
    if off:
        head.append(f"**Not the protocol, not converged by its budget**: {'; '.join(off)}. Its verdicts are a quick look.")
    still = [seed for seed, per in store["seeds_results"].items() if still_improving(per["search"])]
    if still:
        head.append(f"**Not converged by the rule**: seed{'s' if len(still) > 1 else ''} {', '.join(still)} still "
                    f"improve{'s' if len(still) == 1 else ''} by {100 * CONVERGED:g} % or more over the last half of the "
                    "CMA-ES phase: a larger --polish resumes them, and a verdict can still turn.")
    return "\n".join(head)


def design_table(store: dict) -> str:
    rows = []
    for seed, per in store["seeds_results"].items():
        r = per["search"]
        crit = r["criterion"]
        trials = f"{len(crit)} ({r['state'].count('pruned')} pruned, {r['state'].count('failed')} failed)"
        design = (", ".join(f"{k} {number(v, '.4g')}" for k, v in r["best_design"].items())
                  if crit[r["best"]] is not None else "none: no trial ran to the end")
        cma = f"{100 * improvement(r):.2f} %" if "polish_from" in r else "none"
        rows.append([seed, number(crit[0], ".4g"), number(crit[r["best"]], ".4g"), design, trials,
                     f"{100 * tpe_improvement(r):.2f} %", cma, _converged(r, store)])
    return table(["seed", "criterion, nominal", "criterion, tuned", "tuned design", "trials", "last-half improvement: TPE",
                  "CMA-ES (the rule)", f"search (the rule: < {100 * CONVERGED:g} %)"], rows)


def failures_text(store: dict) -> str:
    lines = []
    for seed, per in store["seeds_results"].items():
        failed = per["search"].get("failures", {})
        if failed:
            first = next(iter(failed.items()))
            lines.append(f"- seed {seed}: {len(failed)} trials failed, e.g. trial {first[0]}: {first[1]}")
        for which, errors in per["heldout_errors"].items():
            if errors:
                where, why = next(iter(errors.items()))
                lines.append(f"- seed {seed}, held out on {which}: {len(errors)} runs failed, e.g. {where}: {why}")
        for i, why in per["optimum"]["errors"].items():
            lines.append(f"- seed {seed}, optimum state {i}: {why}")
    return "\n".join(lines) or "No trial and no run failed."


def heldout_table(store: dict, ref: dict) -> str:
    """Geometric mean [95 % BCa interval] of each measure per set: each seed of the controller, then our tuned
    controllers of the same seeds, on the same points (every draw together)."""
    n = store["points"]
    cells = [(which, name) for which in fair.SETS for name in fair.MEASURES]
    rows, samples = [], []
    for seed, per in store["seeds_results"].items():
        rows.append(f"this controller, seed {seed}")
        samples += [per["heldout"][which][name] for which, name in cells]
    for label in OURS:
        for seed in map(str, store["seeds"]):
            if seed in ref["runs"][label]:
                rows.append(f"{label} tuned, seed {seed}")
                samples += [_ours(ref, label, seed, which, name, None, n) for which, name in cells]
    intervals = iter(geometric_intervals(samples))
    body = [[row, *(_cell(next(intervals)) for _ in cells)] for row in rows]
    return table(["configuration", *(f"{which}: {name}" for which, name in cells)], body)


def _verdicts(store: dict, ref: dict) -> tuple[dict, int]:
    """{(set, our label, measure): {(draw, seed): PairedVerdict}}: each seed against the same seed of ours."""
    n, m = store["points"], family(store, ref)
    wanted = {}
    for which in fair.SETS:
        for label in OURS:
            for name in fair.MEASURES:
                wanted[which, label, name] = {(d, s): (k, s) for k, d in enumerate(store["draws"])
                                              for s in map(str, store["seeds"]) if s in ref["runs"][label]}
    asked = [(g, key, k, s) for g, per in wanted.items() for key, (k, s) in per.items()]
    said = iter(paired_verdicts([(_measure(store["seeds_results"][s]["heldout"][g[0]][g[2]], k, n),
                                  _ours(ref, g[1], s, g[0], g[2], k, n)) for g, _, k, s in asked], m))
    return {g: {key: _unless_failed(next(said)) for key in per} for g, per in wanted.items()}, m


def _unless_failed(v: PairedVerdict) -> PairedVerdict:
    """No verdict where this controller failed a run: the pairs keep the points where both ran, so a controller that
    fails its hardest points would be judged on its easy ones only."""
    if not v.failed_a:
        return v
    return replace(v, verdict=f"{FAILED_ON} {v.failed_a} of {v.failed_a + v.ratio.n} points")


def verdict_table(store: dict, ref: dict) -> str:
    verdicts, m = _verdicts(store, ref)
    draws = store["draws"]
    head = (f"Family: on each draw, these {m - ref['family']} verdicts are corrected as members of one family with the "
            f"README's {ref['family']} (m = {m}): each interval here at {100 * level(m):.5g} % (Bonferroni); the README's "
            f"own intervals stay at its family's level, {100 * level(ref['family']):.5g} %. Where this controller failed a "
            "run, no verdict is stated (the pairs would keep only the points where it ran). A is this controller, each seed against the same seed of B; A / B is the geometric mean of the per-point "
            "ratio. A verdict holds only where every draw and every seed gives it, clear of the marginal band (a "
            "corrected bound within 1 % of 1).")
    rows = [[which, f"vs {label} tuned", NOT_TUNED_FOR.get(name, name),
             *(_seeds_cell({k: v for k, v in per.items() if k[0] == d}) for d in draws), _overall(per)]
            for (which, label, name), per in verdicts.items()]
    return head + "\n\n" + table(["set", "A vs B", "measure", *(f"draw {d}" for d in draws), "every draw and seed"], rows)


def _overall(per: dict) -> str:
    """What every draw and seed gives (``fair_tables._every``), or that nothing is stated where A failed a run."""
    if any(v.verdict.startswith(FAILED_ON) for v in per.values()):
        return "not stated: A failed runs"
    return _every(per)


def headline(store: dict, ref: dict) -> str:
    """What every draw and seed gives on the MSE, the measure the tuning judged."""
    verdicts, _ = _verdicts(store, ref)
    held = []
    for (which, label, name), per in verdicts.items():
        said = _agreed(per)
        if name in NOT_TUNED_FOR or said in (None, "not distinguishable") or said.startswith(FAILED_ON):
            continue
        ratios = [v.ratio.value for v in per.values()]
        held.append(f"- {said} than the tuned {label} on the {which} set (A / B {number(min(ratios), '.3g')} to "
                    f"{number(max(ratios), '.3g')} over {len(store['draws'])} draws x {len(store['seeds'])} seeds)")
    failed = sum(1 for per in store["seeds_results"].values() for which in fair.SETS
                 for v in per["heldout"][which]["mse"] if v is None)
    if failed:
        held.append(f"- this controller failed {failed} held-out run{'s' if failed > 1 else ''}: no verdict is stated "
                    "where it failed (\"Failures\" below)")
    still = [seed for seed, per in store["seeds_results"].items() if still_improving(per["search"])]
    if still:
        held.append(f"- not converged by the rule: seed{'s' if len(still) > 1 else ''} {', '.join(still)}")
    return "\n".join(held) or "- no MSE verdict against a tuned controller of ours holds on every draw and seed"


def optimum_table(store: dict, ref: dict) -> str:
    """J / J* at the paper's state and over every stored state (geometric mean [95 % interval])."""
    rows = []
    for seed, per in store["seeds_results"].items():
        r = per["optimum"]["ratios"]
        iv = geometric_interval(r)
        rows.append([f"this controller, seed {seed}", number(r[0], ".4g"), _cell(iv)])
    for label, s in sorted(ref["optimum"]["summary"].items(), key=lambda kv: OURS.index(kv[0].split()[0])):
        if label.rsplit(" ", 1)[-1] in map(str, store["seeds"]):
            rows.append([label, number(s["paper"], ".4g"), f"{number(s['gmean'], '.3g')} [{number(s['low'], '.3g')}, "
                                                          f"{number(s['high'], '.3g')}]"])
    states = len(ref["optimum"]["states"])
    return (f"The stored optimum's {states} states (objective {ref['optimum']['objective']}, "
            f"{ref['optimum']['horizon']:g} s; docs/optimum.md): J of the closed loop by the same cost, over J*.\n\n"
            + table(["configuration", "J / J* at the paper's state", f"J / J* over {states} states"], rows))


def cuts_table(store: dict) -> str:
    rows = []
    for seed, per in store["seeds_results"].items():
        for which in fair.SETS:
            cuts = [c for c in per["heldout"][which]["cuts"] if c is not None]
            rows.append([seed, which, sum(cuts), sum(1 for c in cuts if c), len(cuts)])
    return table(["seed", "set", "samples cut", "runs with a cut", "runs"], rows, "llrrr")


def report(store: dict[str, Any]) -> str:
    ref = reference()
    sections = [("Benchmark", protocol_text(store)), ("What every draw and seed gives (MSE)", headline(store, ref)),
                ("Tuned designs", design_table(store)), ("Held-out figures", heldout_table(store, ref)),
                ("Paired verdicts", verdict_table(store, ref)), ("Against the optimum", optimum_table(store, ref)),
                ("Samples the bound cut", cuts_table(store)), ("Failures", failures_text(store))]
    return "\n\n".join(f"{'#' if i == 0 else '##'} {title}\n\n{body}" for i, (title, body) in enumerate(sections)) + "\n"
