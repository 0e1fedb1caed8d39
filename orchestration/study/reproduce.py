"""``sotc-cosim reproduce``: the paper's section 4 end to end, and Table 1 extended.

Runs through the FMUs the SOTC scenarios (``paper``, its literal and near-literal readings,
``paper-pe-only``) and every controller under every torque-limit handling (``REPRODUCE_RUNS``: the
SOTC, CT and LQR under radial / joint / accel, the OTC unclipped and clipped by each), then writes
Table 1 with the paper's own numbers in their own rows beside ours (``table1.md`` and
``table1.csv``), and the value-function table of the learned W (``orchestration.study.value_function``).
Every number in our rows is read from the summaries of this invocation's runs.
"""
from __future__ import annotations

import csv
import io
import textwrap
from pathlib import Path
from typing import Any, Callable, NamedTuple

from fmu_controller.saturation import LIMIT_HANDLINGS
from orchestration.outputs import atomic_write
from orchestration.markdown import table as markdown_table
from orchestration.run.scenario import Scenario, load_scenario
from orchestration.run.summary import fmt_cell
from orchestration.study.comparison import COMPARED, PAPER_TABLE1, chaos_text
from orchestration.study.sotc_study import NO_LEARNING
from orchestration.study.tuning import CONTROLLERS, NOMINAL_SCENARIO, tuned_parameters


CONSOLE_WIDTH = 120  # columns of what reproduce prints (the full table is table1.md's)
TUNED_HANDLINGS = (2, 0)  # the tuned rows of the README's results table: accel, radial


class Run(NamedTuple):
    """One run of ``reproduce``: a scenario, the limit handling (None: the scenario's own), the run's
    name, whether the controller runs its tuned design (``orchestration.study.tuning``) and whether the
    SOTC's critic learns (False: alpha1 = alpha2 = 1e-9)."""

    scenario: str
    code: int | None
    name: str
    tuned: bool = False
    learning: bool = True

    def overrides(self) -> dict[str, float]:
        """The controller parameters this run sets over its scenario's."""
        out: dict[str, float] = {} if self.code is None else {"limit_handling": self.code}
        if self.tuned:
            out.update(tuned_parameters(load_scenario(self.scenario).controller_fmu(), self.code))
        return out if self.learning else {**out, **NO_LEARNING}


def _runs() -> tuple[Run, ...]:
    """The SOTC readings first, then every controller of ``COMPARED`` under each handling (its default
    under its own name), every controller tuned by the one protocol under ``TUNED_HANDLINGS``, and the
    SOTC with its learning off at its nominal and its tuned designs (paired with the runs before)."""
    runs = [Run("paper-literal", None, "paper-literal"), Run("paper-near-literal", None, "paper-near-literal"),
            Run("paper-pe-only", None, "paper-pe-only")]
    for scenario, codes in COMPARED:
        runs.append(Run(scenario, None, scenario))
        runs += [Run(scenario, code, f"{scenario}-{LIMIT_HANDLINGS[code]}") for code in codes[1:]]
    for fmu in CONTROLLERS:
        scenario = NOMINAL_SCENARIO[fmu]
        runs += [Run(scenario, code, f"{scenario}-tuned-{LIMIT_HANDLINGS[code]}", True) for code in TUNED_HANDLINGS]
    sotc = NOMINAL_SCENARIO["SotcController"]
    runs.append(Run(sotc, None, f"{sotc}-learning-off", learning=False))
    runs += [Run(sotc, code, f"{sotc}-tuned-{LIMIT_HANDLINGS[code]}-learning-off", True, False) for code in TUNED_HANDLINGS]
    return tuple(runs)


REPRODUCE_RUNS = _runs()
REPRODUCE_SCENARIOS = tuple(r.name for r in REPRODUCE_RUNS)


def reproduce_scenarios() -> list[Scenario]:
    out = []
    for run in REPRODUCE_RUNS:
        sc, overrides = load_scenario(run.scenario), run.overrides()
        out.append(sc.with_parameters({f"controller.{k}": v for k, v in overrides.items()}, name=run.name)
                   if run.name != run.scenario else sc)
    return out


def learning_pairs() -> list[tuple[Run, Run]]:
    """(learning on, learning off) for every SOTC run whose learning-off twin ``reproduce`` runs."""
    on = {(r.scenario, r.code, r.tuned): r for r in REPRODUCE_RUNS if r.learning}
    return [(on[(r.scenario, r.code, r.tuned)], r) for r in REPRODUCE_RUNS if not r.learning]


def chaos_notes(summaries: list[dict[str, Any]]) -> dict[str, str]:
    """Run name -> ``chaos_text`` for every SOTC reading of this invocation (untuned, learning) whose
    Table 1 metric is chaotic at its stop time (the pure loop, which equals the FMU runs)."""
    from orchestration.run import interrupt

    stop = {s["scenario"]: s["stop_time"] for s in summaries}
    out = {}
    for run in REPRODUCE_RUNS:
        if (run.name in stop and not run.tuned and run.learning and not interrupt.requested()
                and load_scenario(run.scenario).controller_fmu() == "SotcController"):
            text = chaos_text(run.scenario, stop[run.name], **run.overrides())
            if text is not None:
                out[run.name] = text
    return out


def learning_lines(summaries: list[dict[str, Any]]) -> list[str]:
    """What the critic's learning adds, per pair: Table 1's metric with learning and without."""
    by = {s["scenario"]: s for s in summaries}
    lines = []
    for on, off in learning_pairs():
        a, b = by.get(on.name, {}), by.get(off.name, {})
        if a.get("mse") and b.get("mse") and None not in a["mse"] + b["mse"]:
            m_on, m_off = sum(a["mse"]), sum(b["mse"])
            lines.append(f"{on.name}: MSE_1 + MSE_2 {m_on:.4g} with learning, {m_off:.4g} without "
                         f"(on / off {m_on / m_off:.3g}); realised cost {a['tracking_cost']:.4g} / {b['tracking_cost']:.4g}")
    return lines


def _text(v: Any, fmt: str, full: bool) -> str:
    return "" if v is None else (repr(v) if full and isinstance(v, float) else format(v, fmt))


def _joint(key: str, joint: int, fmt: str) -> Callable[[dict[str, Any], bool], str]:
    def get(s: dict[str, Any], full: bool = False) -> str:
        v = s.get(key)
        return "" if v is None else _text(v[joint], fmt, full)

    return get


def _scalar(key: str, fmt: str) -> Callable[[dict[str, Any], bool], str]:
    def get(s: dict[str, Any], full: bool = False) -> str:
        return _text(s.get(key), fmt, full)

    return get


# (column title, unit, extractor from a run summary)
COLUMNS: list[tuple[str, str, Callable[[dict[str, Any]], str]]] = [
    ("limit handling", "", lambda s, full=False: s.get("limit_handling") or ""),
    ("MSE joint 1", "rad^2", _joint("mse", 0, ".5f")),
    ("MSE joint 2", "rad^2", _joint("mse", 1, ".5f")),
    ("MSE1 t>=5s", "rad^2", _joint("mse_after_5s", 0, ".3e")),
    ("MSE2 t>=5s", "rad^2", _joint("mse_after_5s", 1, ".3e")),
    ("MSE1 after last limit", "rad^2", _joint("mse_after_limit", 0, ".3e")),
    ("MSE2 after last limit", "rad^2", _joint("mse_after_limit", 1, ".3e")),
    ("last limit sample", "s", _scalar("last_limit_time", ".2f")),
    ("realised cost int z'z", "", _scalar("tracking_cost", ".4f")),
    ("RMSE joint 1", "rad", _joint("rmse", 0, ".4f")),
    ("RMSE joint 2", "rad", _joint("rmse", 1, ".4f")),
    ("IAE joint 1", "rad.s", _joint("iae", 0, ".4f")),
    ("IAE joint 2", "rad.s", _joint("iae", 1, ".4f")),
    ("max|e1| t>=20s", "rad", _joint("max_abs_error_after_20s", 0, ".2e")),
    ("max|e2| t>=20s", "rad", _joint("max_abs_error_after_20s", 1, ".2e")),
    ("max|e1| t>=50s", "rad", _joint("max_abs_error_after_50s", 0, ".2e")),
    ("max|e2| t>=50s", "rad", _joint("max_abs_error_after_50s", 1, ".2e")),
    ("t(|e1|<0.01)", "s", _joint("settle_time_10mrad", 0, ".2f")),
    ("t(|e2|<0.01)", "s", _joint("settle_time_10mrad", 1, ".2f")),
    ("max|tau1|", "N.m", _joint("max_abs_tau", 0, ".3f")),
    ("max|tau2|", "N.m", _joint("max_abs_tau", 1, ".3f")),
    ("max||tau||", "N.m", _scalar("max_norm_tau", ".3f")),
    ("samples at limit", "", _scalar("samples_at_limit", "d")),
    ("samples over limit", "", _scalar("samples_over_limit", "d")),
    ("energy int tau'tau", "N^2.m^2.s", _scalar("control_energy", ".1f")),
    ("TV(tau1)/s", "N.m/s", _joint("tau_total_variation_rate", 0, ".3f")),
    ("TV(tau2)/s", "N.m/s", _joint("tau_total_variation_rate", 1, ".3f")),
    ("own cost int (cost_rate)", "", _scalar("cost_integral", ".3f")),
    # the actuator's cuts of a controller from an FMU file (reproduce --with; docs/benchmark.md): 0 for ours
    ("samples cut", "", _scalar("torque_cuts", "d")),
]


CHAOTIC_CELLS = slice(1, 7)  # of COLUMNS: MSE, MSE for t >= 5 s and after the last limit sample


def table_rows(summaries: list[dict[str, Any]], full: bool = False,
               chaotic: frozenset[str] = frozenset()) -> tuple[list[str], list[list[str]]]:
    """Header and rows: the paper's rows first (MSE only), then one row per run of ours; ``full``:
    every number at full precision (``repr``, for table1.csv) instead of the column's format; the
    MSE cells of the ``chaotic`` runs say so instead of printing a number that is not reproducible."""
    header = ["source", "scenario", "controller", "status"] + [
        f"{title} [{unit}]" if unit else title for title, unit, _ in COLUMNS
    ]
    rows: list[list[str]] = []
    for name, (m1, m2) in PAPER_TABLE1.items():
        rows.append(["paper Table 1", "", name, ""] + ["", f"{m1:.5f}", f"{m2:.5f}"] + [""] * (len(COLUMNS) - 3))
    for s in summaries:
        cells = [get(s, full) for _, _, get in COLUMNS]
        if s["scenario"] in chaotic:
            cells[CHAOTIC_CELLS] = ["chaotic (see below)"] * (CHAOTIC_CELLS.stop - CHAOTIC_CELLS.start)
        rows.append(["this run", s["scenario"], str(s["controller"]), s["status"]] + cells)
    return header, rows


def to_csv(header: list[str], rows: list[list[str]]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buf.getvalue()


def value_table(summaries: list[dict[str, Any]]) -> str:
    """The value-function measures (``orchestration.study.value_function``) of the W the ``paper`` run of
    this invocation learned, beside W = 0, the paper's W and the LQR weights (horizon: the stop time,
    at most 20 s)."""
    from orchestration.run import interrupt
    from orchestration.study.sotc_study import run
    from orchestration.study.value_function import HORIZON, value_report, value_rows

    if interrupt.requested():  # Ctrl-C: write what finished now, not seconds of extra runs later
        return "(no value-function table: the invocation was interrupted)\n"
    paper = next((s for s in summaries if s["scenario"] == "paper" and s.get("final_weights")), None)
    if paper is None:
        return "(no value-function table: the `paper` run did not finish)\n"
    _, visited = run("paper", stop_time=paper["stop_time"])  # the pure loop: the FMU run's samples, bit for bit
    return value_report(value_rows(paper["final_weights"], visited, min(HORIZON, paper["stop_time"]))) + "\n"


def _stop_times(summaries: list[dict[str, Any]]) -> str:
    times = sorted({s["stop_time"] for s in summaries})
    return " / ".join(f"{t:g} s" for t in times) if times else "-"


def sections(summaries: list[dict[str, Any]], notes: dict[str, str]) -> str:
    """The chaotic readings said as such, and what the critic's learning adds, as text lines."""
    out = []
    if notes:
        out += ["Chaotic readings (only a lower bound of their MSE is reproducible):"]
        out += [f"  {name}: {text}" for name, text in notes.items()]
    pairs = learning_lines(summaries)
    if pairs:
        out += ["What the critic's learning adds (the same run with alpha1 = alpha2 = 1e-9):"] + [f"  {p}" for p in pairs]
    return "\n".join(out)


def write_table(summaries: list[dict[str, Any]], out_dir: Path, notes: dict[str, str]) -> tuple[Path, Path]:
    """table1.md (every column: too wide for a terminal, which gets ``compact_table``) and table1.csv."""
    header, rows = table_rows(summaries, chaotic=frozenset(notes))
    out_dir = Path(out_dir)
    md, cs = out_dir / "table1.md", out_dir / "table1.csv"
    text = markdown_table(header, rows) + "\n"
    extra = sections(summaries, notes)
    atomic_write(md,
        "# Table 1 of the paper, extended\n\n"
        "Rows 'paper Table 1' are the paper's numbers (it reports MSE only, over 100 s); rows 'this run' are\n"
        "measured by this invocation of `sotc-cosim reproduce` (metrics defined in orchestration/run/metrics.py),\n"
        f"stop time {_stop_times(summaries)}.\n\n" + text + (f"\n```\n{extra}\n```\n" if extra else "")
        + "\n## The learned value function (docs/paper-notes.md, section 3.1)\n\n" + value_table(summaries)
    )
    atomic_write(cs, to_csv(*table_rows(summaries, full=True)))
    return md, cs


def compact_table(summaries: list[dict[str, Any]], notes: dict[str, str]) -> str:
    """The console version (under 120 columns): what the rows are and the run's stop time, MSE beside the
    paper's (a chaotic reading's MSE: see the notes below), the torque bound, then ``sections``."""
    w = max(22, *(len(s["scenario"]) for s in summaries)) if summaries else 22
    lines = [f"rows 'paper': the paper's Table 1 (MSE over 100 s); the others: this run, stop time {_stop_times(summaries)}",
             f"{'':<{w}} {'controller':<10} {'limit':<6} {'MSE 1':>9} {'MSE 2':>9} {'MSE1 t>=5':>9} "
             f"{'MSE2 t>=5':>9} {'cost':>8} {'max||tau||':>10} {'over limit':>10}"]
    for name, (m1, m2) in PAPER_TABLE1.items():
        bound = "<= 4" if name == "SOTC" else "?"  # the paper states the bound for SOTC only
        lines.append(f"{'paper':<{w}} {name:<10} {'':<6} {m1:>9.5f} {m2:>9.5f} {'':>9} {'':>9} {'':>8} {bound:>10} {'':>10}")
    for s in summaries:
        mse = s.get("mse") or [None, None]
        late = s.get("mse_after_5s") or [None, None]
        first = (f"{fmt_cell(mse[0], '.4g', 9)} {fmt_cell(mse[1], '.4g', 9)} {fmt_cell(late[0], '.3g', 9)} "
                 f"{fmt_cell(late[1], '.3g', 9)}")
        if s["scenario"] in notes:
            first = f"{'chaotic: see below':>39}"
        controller = str(s["controller"]).removesuffix("Controller")  # SotcController: Sotc, as the paper's SOTC
        controller = "FMU file" if controller.endswith(".fmu") else controller  # reproduce --with: its row's name says
        lines.append(
            f"{s['scenario']:<{w}} {controller:<10} {s.get('limit_handling') or '-':<6} {first} "
            f"{fmt_cell(s.get('tracking_cost'), '.4g', 8)} "
            f"{fmt_cell(s.get('max_norm_tau'), '.4g', 10)} {fmt_cell(s.get('samples_over_limit'), 'd', 10)}"
        )
    lines += [wrapped for line in sections(summaries, notes).splitlines()
              for wrapped in textwrap.wrap(line, CONSOLE_WIDTH, subsequent_indent="    ")]
    return "\n".join(lines)
