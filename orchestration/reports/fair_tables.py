"""The generated blocks of the fair comparison: the tuning protocol's result, the paired statistics and
the verdict sentences, all from the stored runs (``orchestration.study.tuning.TUNED_FILE``,
``orchestration.study.fair.STORE``) so that tests/docs/test_docgen.py checks them in the ordinary
suite; tests/docs/test_fair_store.py re-runs a sample of the stored runs."""
from __future__ import annotations

from pathlib import Path

from fmu_controller.catalog import LABELS
from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.markdown import number, table
from orchestration.study.fair import MEASURES, SETS, measure, stored
from orchestration.study.statistics import Interval, geometric_interval, paired
from orchestration.study.tuning import BUDGET, CONTROLLERS, HANDLINGS
from orchestration.study.tuning import stored as stored_tuning

VERDICT_HANDLING = "accel"  # the handling the README's verdict is stated under (all three are in docs/robustness.md)


def design_text(design: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in design.items())


def tuning_table() -> str:
    """Per controller and handling: the criterion at the nominal design, the best of the budget and its design."""
    data = stored_tuning()
    rows = []
    for fmu in CONTROLLERS:
        for h in HANDLINGS:
            r = data["controllers"][fmu]["handlings"][LIMIT_HANDLINGS[h]]
            crit = r["criterion"]
            failed = sum(v is None for v in crit)
            rows.append([LABELS[fmu], LIMIT_HANDLINGS[h], number(crit[0], ".4g"), number(crit[r["best"]], ".4g"),
                         "nominal" if r["best"] == 0 else design_text(r["best_design"]), f"{BUDGET} ({failed} failed)"])
    return table(["controller", "limit handling", "MSE_1 + MSE_2, nominal", "MSE_1 + MSE_2, tuned",
                  "tuned design", "points evaluated"], rows)


def _cell(i: Interval) -> str:
    text = f"{number(i.value, '.3g')} [{number(i.low, '.3g')}, {number(i.high, '.3g')}]"
    return text + (f", {i.failed} failed" if i.failed else "")


def summary_table(root: Path, which: str) -> str:
    """Every configuration on one evaluation set: geometric mean [95 % interval] of each measure."""
    data = stored(root)
    labels = list(data["runs"][VERDICT_HANDLING])
    rows = []
    for label in labels:
        row = [label]
        for h in HANDLINGS:
            for name in MEASURES:
                row.append(_cell(geometric_interval(measure(data, LIMIT_HANDLINGS[h], label, which, name))))
        rows.append(row)
    header = ["configuration"] + [f"{LIMIT_HANDLINGS[h]}: {name}" for h in HANDLINGS for name in MEASURES]
    return table(header, rows)


def _pairs(labels: list[str]) -> list[tuple[str, str]]:
    sotc = LABELS["SotcController"]
    out = []
    for design in ("tuned", "nominal"):
        out += [(f"{sotc} {design}", f"{LABELS[f]} {design}") for f in CONTROLLERS if f != "SotcController"]
    out += [(f"{sotc} {d}", f"{sotc} {d}, learning off") for d in ("nominal", "tuned")]
    out += [(f"{LABELS[f]} tuned", f"{LABELS[f]} nominal") for f in CONTROLLERS]
    return [p for p in out if p[0] in labels and p[1] in labels]


def paired_table(root: Path) -> str:
    """A against B on the same points: geometric mean of A / B [95 % interval] and the verdict."""
    data = stored(root)
    rows = []
    for which in SETS:
        for h in HANDLINGS:
            handling = LIMIT_HANDLINGS[h]
            for a, b in _pairs(list(data["runs"][handling])):
                cells = []
                for name in MEASURES:
                    v = paired(measure(data, handling, a, which, name), measure(data, handling, b, which, name))
                    cells += [_cell(v.ratio), v.verdict]
                rows.append([which, handling, f"{a} vs {b}", *cells])
    header = ["set", "limit handling", "A vs B"] + [c for name in MEASURES for c in (f"{name}: A / B", f"{name}: A is")]
    return table(header, rows)


def verdict(root: Path) -> str:
    """README's sentences: the tuned SOTC against each tuned baseline, and what learning adds."""
    data = stored(root)
    runs = data["runs"][VERDICT_HANDLING]
    sotc = LABELS["SotcController"]
    lines = []
    for which in SETS:
        parts = []
        for a, b in _pairs(list(runs)):
            if not (a == f"{sotc} tuned" and b.endswith(" tuned")):
                continue
            said = []
            for name in MEASURES:
                v = paired(measure(data, VERDICT_HANDLING, a, which, name), measure(data, VERDICT_HANDLING, b, which, name))
                said.append(f"{name} {v.verdict} (A / B {_cell(v.ratio)})")
            parts.append(f"against {b}: " + ", ".join(said))
        lines.append(f"On the {which} set ({data['n_points']} points never used for tuning, {data['stop_time']:g} s, "
                     f"all under {VERDICT_HANDLING}), the tuned SOTC is " + "; ".join(parts) + ".")
    for which in SETS:
        said = []
        for d in ("nominal", "tuned"):
            v = paired(measure(data, VERDICT_HANDLING, f"{sotc} {d}", which, "tail"),
                       measure(data, VERDICT_HANDLING, f"{sotc} {d}, learning off", which, "tail"))
            said.append(f"at the {d} design {v.verdict} (on / off {_cell(v.ratio)})")
        lines.append(f"What the critic's learning adds on the {which} set (post-transient error, learning on "
                     f"against off): " + "; ".join(said) + ".")
    return "\n".join(f"- {line}" for line in lines)
