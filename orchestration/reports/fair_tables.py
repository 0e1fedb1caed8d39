"""The generated blocks of the fair comparison: the tuning protocol's result, the paired statistics, the
verdict table per draw of the held-out points and the README's verdict, all from the stored runs (``orchestration.study.tuning.TUNED_FILE``,
``orchestration.study.fair.STORE``) so that tests/docs/test_docgen.py checks them in the ordinary
suite; tests/docs/test_fair_store.py re-runs a sample of the stored runs.

Each table that states verdicts names its family (the verdicts it states together) and takes every
interval at the Bonferroni level of that family (``orchestration.study.statistics``)."""
from __future__ import annotations

import functools
import json
import math
from collections import Counter

from pathlib import Path

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.markdown import number, table
from orchestration.study.fair import MEASURES, SETS, STORE, measure, stored, tuned_label
from orchestration.study.statistics import Interval, PairedVerdict, geometric_intervals, level, paired_verdicts
from orchestration.study.tuning import CONTROLLERS, CONVERGED, HANDLINGS, improvement, still_improving, tpe_improvement, unconverged
from orchestration.study.tuning import stored as stored_tuning

# The tuning criterion is the MSE on the training points (orchestration.study.tuning): a verdict on another
# measure judges what no search was tuned for, and says so (docs/baselines.md, "What the criterion judges").
NOT_TUNED_FOR = {"tail": "tail (not tuned for)"}
VERDICT_HANDLING = "accel"  # the handling the verdict is stated under (all three: the tables of docs/robustness*.md)
SOTC = "SotcController"
BASELINES = tuple(f for f in CONTROLLERS if f != SOTC)


def design_text(design: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in design.items())


def _searches():
    data = stored_tuning()
    for fmu in CONTROLLERS:
        for h in HANDLINGS:
            for seed, r in data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[h]]["seeds"].items():
                yield fmu, LIMIT_HANDLINGS[h], seed, r


def tuning_table() -> str:
    """Per controller, handling and seed: the criterion at the nominal design (the first trial), the best
    of the search and its design, the trials, and how much the best-so-far fell over the last half of the
    TPE phase and of the CMA-ES phase (the rule's)."""
    rows = []
    for fmu, handling, seed, r in _searches():
        crit = r["criterion"]
        trials = f"{len(crit)} ({r['state'].count('pruned')} pruned, {r['state'].count('failed')} failed)"
        rows.append([LABELS[fmu], handling, seed, number(crit[0], ".4g"), number(crit[r["best"]], ".4g"),
                     "nominal" if r["best"] == 0 else design_text(r["best_design"]), trials,
                     f"{100 * tpe_improvement(r):.2f} %", f"{100 * improvement(r):.2f} %" if "polish_from" in r else "none"])
    return table(["controller", "limit handling", "seed", "criterion, nominal", "criterion, tuned", "tuned design",
                  "trials", "last-half improvement: TPE", "CMA-ES (the rule)"], rows)


def _rule(data) -> str:
    if not data.get("polish"):
        return (f"best-so-far improves by less than {100 * CONVERGED:g} % over the last half of the trials, stated before the "
                "search")
    return (f"over the last half of the CMA-ES phase, both the search's best-so-far and the phase's own best-so-far "
            f"improve by less than {100 * CONVERGED:g} %: doubling the local search moves neither by that much. Stated "
            "after the TPE phase ran, its second part after the first 128 CMA-ES trials, when a review found phases "
            "that never came back down to their start read 0 on the first")


def tuning_summary() -> str:
    """The budget, whether every search converged by the stated rule, and what the stored study cost."""
    data = stored_tuning()
    worst = max(_searches(), key=lambda s: improvement(s[3]))
    over = [f"{LABELS[f]} {h} seed {s} ({100 * improvement(r):.1f} %)" for f, h, s, r in _searches() if still_improving(r)]
    tpe_worst = max(_searches(), key=lambda s: tpe_improvement(s[3]))
    tpe_over = sum(1 for *_, r in _searches() if tpe_improvement(r) >= CONVERGED)
    searches = sum(1 for _ in _searches())
    hours = data["trial_seconds"] / 3600
    converged = (f"every search meets it; the largest is {100 * improvement(worst[3]):.2f} % "
                 f"({LABELS[worst[0]]} {worst[1]} seed {worst[2]})"
                 if not over else
                 f"{searches - len(over)} of {searches} searches meet it; not {', '.join(over)}: those searches were "
                 "still improving, so the budget is not yet enough by the rule (a larger budget resumes every search "
                 "where it stopped)")
    phases = (f"{data['budget']} trials of TPE, then {data['polish']} of CMA-ES from the best"
              if data.get("polish") else f"{data['budget']} trials")
    lines = [
        f"- Budget: {phases}, for every controller under every limit handling, seeds "
        f"{', '.join(map(str, data['seeds']))} ({searches} searches; the store is "
        f"{'complete' if data['complete'] else 'INCOMPLETE'}); training set: {data['training_points']} points.",
        f"- The rule ({_rule(data)}): {converged}."]
    if data.get("polish"):
        lines.append(f"- The TPE phase alone, by the same test over its own last half: {searches - tpe_over} of "
                     f"{searches} searches under {100 * CONVERGED:g} %; the largest {100 * tpe_improvement(tpe_worst[3]):.2f} % "
                     f"({LABELS[tpe_worst[0]]} {tpe_worst[1]} seed {tpe_worst[2]}): a global search's best moves in "
                     "jumps between basins, which is why the rule judges the local phase and the seeds sample the basins.")
    if data.get("polish"):
        lines.append(_start_text(searches))
    lines.append(
        f"- Cost: {hours:.2f} h of trials (the sum of every trial's wall time, pruned trials stopping early), "
        f"run from {_clock(min(r['started'] for *_, r in _searches()))} to "
        f"{_clock(max(r['finished'] for *_, r in _searches()))} UTC "
        f"on this 2-core machine shared with other work ({data['sampler']}).")
    return "\n".join(lines)


def _start_text(searches: int) -> str:
    """In how many searches CMA-ES found a design better than its start (the TPE best)."""
    above = []
    for *_, r in _searches():
        start = r["polish_from"]
        tpe = min(v for v in r["criterion"][:start] if v is not None)
        cma = min((v for v in r["criterion"][start:] if v is not None), default=None)
        if cma is None or cma >= tpe:
            above.append(math.inf if cma is None else cma / tpe - 1)
    return (f"- CMA-ES found a design better than its start in {searches - len(above)} of {searches} searches; in the "
            f"other {len(above)} the TPE best stands, better than everything CMA-ES tried around it (whose best was "
            f"up to {100 * max(above, default=0):.2f} % above it).")


def _clock(iso: str) -> str:
    return iso[:16].replace("T", " ")


def _cell(i: Interval) -> str:
    text = f"{number(i.value, '.3g')} [{number(i.low, '.3g')}, {number(i.high, '.3g')}]"
    return text + (f", {i.failed} failed" if i.failed else "")


def _ratio(v: PairedVerdict) -> str:
    return f"{_cell(v.ratio)}, worse on {v.worse_on} of {v.ratio.n}"


def summary_table(root: Path, which: str) -> str:
    """Every configuration on one evaluation set, every draw's points together: geometric mean [95 % interval]
    of each measure."""
    data = stored(root)
    labels = list(data["runs"][VERDICT_HANDLING])
    cells = [(LIMIT_HANDLINGS[h], name) for h in HANDLINGS for name in MEASURES]
    intervals = iter(geometric_intervals([measure(data, handling, label, which, name)
                                          for label in labels for handling, name in cells]))
    rows = [[label, *(_cell(next(intervals)) for _ in cells)] for label in labels]
    header = ["configuration"] + [f"{handling}: {name}" for handling, name in cells]
    return table(header, rows)


def _pairs(seeds: list) -> list[tuple[str, str]]:
    """The SOTC against each baseline (tuned: seed against the same seed; nominal), learning on against
    off at every SOTC design, and each controller tuned against nominal."""
    sotc = LABELS[SOTC]
    out = [(tuned_label(SOTC, s), tuned_label(f, s)) for s in seeds for f in BASELINES]
    out += [(f"{sotc} nominal", f"{LABELS[f]} nominal") for f in BASELINES]
    out += [(d, f"{d}, learning off") for d in [f"{sotc} nominal", *(tuned_label(SOTC, s) for s in seeds)]]
    out += [(tuned_label(f, s), f"{LABELS[f]} nominal") for f in CONTROLLERS for s in seeds]
    return out


def _family_text(m: int) -> str:
    return f"each interval at {100 * level(m):.5g} % (Bonferroni: all {m} hold together with at least 95 %)"


def paired_table(root: Path) -> str:
    """A against B on the same points of each draw: geometric mean of A / B [interval], the sign count, the
    verdict; each draw's verdicts are one family."""
    data = stored(root)
    pairs = _pairs(data["seeds"])
    m = len(SETS) * len(HANDLINGS) * len(pairs) * len(MEASURES)
    keys = [(which, LIMIT_HANDLINGS[h], a, b, d) for which in SETS for h in HANDLINGS for a, b in pairs
            for d in data["draws"]]
    verdicts = iter(paired_verdicts([(measure(data, handling, a, which, name, d), measure(data, handling, b, which, name, d))
                                     for which, handling, a, b, d in keys for name in MEASURES], m))
    rows = []
    for which, handling, a, b, d in keys:
        cells = []
        for v in (next(verdicts) for _ in MEASURES):
            cells += [_ratio(v), v.said]
        rows.append([which, handling, f"{a} vs {b}", d, *cells])
    header = ["set", "limit handling", "A vs B", "draw"] + [c for name in MEASURES for c in (f"{name}: A / B", f"{name}: A is")]
    return (f"Family: on each draw, the {m} verdicts of that draw, {_family_text(m)}.\n\n"
            + table(header, rows))


def _agreed(verdicts: dict) -> str | None:
    """The verdict every one of ``verdicts`` gives clear of the marginal band (a bound within 1 % of 1: a new
    draw of the tuning seeds turned such verdicts); None where they differ or one is marginal."""
    said = {v.verdict for v in verdicts.values()}
    return None if len(said) > 1 or any(v.marginal for v in verdicts.values()) else said.pop()


def _seeds_cell(verdicts: dict) -> str:
    """One draw's verdicts over the tuning seeds: how many seeds say what, and the range of A / B."""
    counts = Counter(v.said for v in verdicts.values())
    ratios = [v.ratio.value for v in verdicts.values()]
    if len(verdicts) == 1:  # the nominal design: one verdict
        return f"{next(iter(counts))}; A / B {number(ratios[0], '.3g')}"
    said = ", ".join(f"{text} {n}" for text, n in counts.most_common())
    return f"{said} of {len(verdicts)} seeds; A / B {number(min(ratios), '.3g')}-{number(max(ratios), '.3g')}"


def _every(verdicts: dict) -> str:
    """What every draw and tuning seed gives, or why nothing is stated."""
    agreed = _agreed(verdicts)
    if agreed is not None:
        return f"**{agreed}**"
    return "marginal" if len({v.verdict for v in verdicts.values()}) == 1 else "depends on the draw or seed"


def readme_family(seeds: list) -> int:
    """The verdicts stated together on one draw of the held-out points (docs/robustness.md, "The verdict"): the tuned
    SOTC against each tuned baseline per measure, set and seed, and learning on against off at each SOTC design per
    set. A verdict stated for every draw is the conjunction of the draws' families, so it errs less often than one."""
    return len(SETS) * (len(seeds) * len(BASELINES) * len(MEASURES) + 1 + len(seeds))


def _verdicts(data: dict) -> tuple[dict, int, dict]:
    """The family's verdicts in the stored runs ``data``, each per (draw, tuning seed): {(set, baseline, measure):
    {(draw, seed): PairedVerdict}} for the tuned SOTC against each tuned baseline, and {(set, design): {(draw,
    seed): ...}} for learning on against off (the nominal design: seed None)."""
    seeds, draws = data["seeds"], data["draws"]
    m = readme_family(seeds)
    sotc = LABELS[SOTC]
    wanted: dict[tuple, dict[tuple, tuple]] = {}  # group -> (draw, seed) -> (A, B, set, measure, draw)
    for which in SETS:
        for f in BASELINES:
            for name in MEASURES:
                wanted[which, f, name] = {(d, s): (tuned_label(SOTC, s), tuned_label(f, s), which, name, d)
                                          for d in draws for s in seeds}
    for which in SETS:
        wanted[which, "nominal"] = {(d, None): (f"{sotc} nominal", f"{sotc} nominal, learning off", which, "tail", d)
                                    for d in draws}
        wanted[which, "tuned"] = {(d, s): (tuned_label(SOTC, s), f"{tuned_label(SOTC, s)}, learning off", which, "tail", d)
                                  for d in draws for s in seeds}
    asked = [args for per in wanted.values() for args in per.values()]
    said = iter(paired_verdicts([(measure(data, VERDICT_HANDLING, a, which, name, d),
                                  measure(data, VERDICT_HANDLING, b, which, name, d)) for a, b, which, name, d in asked], m))
    verdicts = {group: {k: next(said) for k in per} for group, per in wanted.items()}
    against = {g: v for g, v in verdicts.items() if len(g) == 3}
    learning = {g: v for g, v in verdicts.items() if len(g) == 2}
    return against, m, learning


def _stored_verdicts(root: Path) -> tuple[dict, dict, int, dict]:
    """(the stored runs, ``_verdicts`` of them): the verdict table and the README's headline take the same family of
    bootstraps, computed once per content of the store in a process."""
    return _verdicts_of((root / STORE).read_bytes())


@functools.lru_cache(maxsize=1)
def _verdicts_of(text: bytes) -> tuple[dict, dict, int, dict]:
    data = json.loads(text)
    return (data, *_verdicts(data))


def _by_draw(verdicts: dict, draws: list) -> list[str]:
    return [_seeds_cell({k: v for k, v in verdicts.items() if k[0] == d}) for d in draws]


def verdict(root: Path) -> str:
    """The verdict (docs/robustness.md): the tuned SOTC against each tuned baseline, and what learning adds, on
    each draw of the held-out points, and what every draw and tuning seed gives."""
    data, against, m, learning = _stored_verdicts(root)
    draws = data["draws"]
    head = (f"Family: on each draw, the {m} verdicts of that draw, {_family_text(m)}. Each draw is {data['n_points']} points per set never "
            f"used for tuning, {data['stop_time']:g} s each, all under {VERDICT_HANDLING}; A is the tuned SOTC, each "
            "seed against the same seed of B. A verdict holds only where every draw and every tuning seed gives it, "
            "clear of the marginal band (a corrected bound within 1 % of 1). The tuning criterion is the MSE; the tail "
            "verdicts judge what no search was tuned for.")
    header = ["set", "A vs B", "measure", *(f"draw {d}" for d in draws), "every draw and seed"]
    rows = [[which, f"SOTC vs {LABELS[f]} tuned", NOT_TUNED_FOR.get(name, name), *_by_draw(per, draws), _every(per)]
            for (which, f, name), per in against.items()]
    rows += [[which, f"learning on vs off, {design} design{'s' if design == 'tuned' else ''}", NOT_TUNED_FOR["tail"],
              *_by_draw(per, draws), _every(per)] for (which, design), per in learning.items()]
    return head + "\n\n" + table(header, rows)


def _converged_text(still: list[str]) -> str:
    """Whether the searches converged by the stated rule; those still improving under the verdict's handling named."""
    if not still:
        return "every search converged by the stated rule"
    judged = [s for s in still if f" {VERDICT_HANDLING} " in s]
    if judged:
        return f"NOT converged by the stated rule: {', '.join(judged)}"
    return f"every {VERDICT_HANDLING} search converged by the stated rule, {len(still)} under other handlings not yet"


def headline(root: Path) -> str:
    """README: only what every tuning seed gives, clear of the marginal band, on the criterion the tuning judged
    (the MSE): the tuned SOTC better or worse than a tuned baseline. Everything else is in docs/robustness.md."""
    data, against, m, _ = _stored_verdicts(root)
    held = []
    for (which, f, name), per in against.items():
        said = _agreed(per)
        if name in NOT_TUNED_FOR or said in (None, "not distinguishable"):
            continue
        ratios = [v.ratio.value for v in per.values()]
        held.append(f"{said} than {LABELS[f]} on the {which} set ({name}, A / B {number(min(ratios), '.3g')} "
                    f"to {number(max(ratios), '.3g')} over {len(data['draws'])} draws x {len(data['seeds'])} seeds)")
    tuning = stored_tuning()
    converged = _converged_text(unconverged(tuning))
    trials = (f"{tuning['budget']} TPE then {tuning['polish']} CMA-ES trials" if tuning.get("polish")
              else f"{tuning['budget']} trials")
    lines = [f"Tuned for the MSE by one protocol (seeds {', '.join(map(str, data['seeds']))}, {trials} "
             f"per search, {converged}),",
             f"judged under {VERDICT_HANDLING} on {len(data['draws'])} independent draws of {data['n_points']} points per "
             f"set that no search saw, {m} paired verdicts corrected together on each draw. What every draw and seed gives:", ""]
    lines += [f"- the tuned SOTC is {h}" for h in held] or [
        "- no MSE verdict of the tuned SOTC against a tuned baseline (each depends on the draw or seed, or is marginal)"]
    return "\n".join(lines + ["", "Every other comparison is not distinguishable, depends on the draw or the tuning seed, is marginal "
                               "or judges what no search was tuned for: [docs/robustness.md](docs/robustness.md#the-verdict)."])
