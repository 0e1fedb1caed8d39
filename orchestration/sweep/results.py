"""A sweep's output folder (default ``recordings/<sweep>/``) and the reports written from it.

- ``points.jsonl``: one JSON line per finished point, appended (and flushed) as it arrives: index,
  resume key, settings, status, failure reason, wall time and the full run summary. This is the
  store: resume reads it, every table below is written from it.
- ``points.csv``: one row per point of the sweep, sorted by index (the same file and seed give the
  same table: no wall times in it).
- ``summary.md``: per-axis aggregates (mean, std, worst case, failures) and the failed points.
- ``plots/<axis>.png``: per axis, the post-transient tracking error and the torque peak per point.
- ``traces/<key>.npy``: the thinned tracking error of each point, for ``sweep.rrd``, the overlay
  of every point's tracking errors; ``points/<key>.rrd``: each point's recording (``--record``).
"""
from __future__ import annotations

import csv
import io
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from orchestration.outputs import OutputError, atomic_file, atomic_write
from orchestration.markdown import number, replace_block, table
from orchestration.sweep.spec import Axis, Sweep

TABLE_INTERVAL_S = 1.0
TABLE_METRICS = (  # (column, summary key, joint index or None)
    ("mse_1", "mse", 0), ("mse_2", "mse", 1),
    ("tail_max_abs_e1", "max_abs_error_last_half", 0), ("tail_max_abs_e2", "max_abs_error_last_half", 1),
    ("max_norm_tau", "max_norm_tau", None), ("samples_over_limit", "samples_over_limit", None),
)


# the actuator's cuts of a controller from an FMU file (docs/benchmark.md), a column where a point runs one
CUT_METRIC = ("samples_cut", "torque_cuts", None)


def table_metrics(sweep: Sweep) -> tuple:
    """``TABLE_METRICS``, and ``CUT_METRIC`` where a point's controller is an FMU file (ours bound themselves: 0)."""
    hosted = bool(sweep.files) or any(inst.contract for inst in sweep.base.instances.values())
    return TABLE_METRICS + (CUT_METRIC,) if hosted else TABLE_METRICS


ROW_FIELDS = {"index": int, "key": str, "settings": dict, "status": str}  # what a stored point has at least


def _stored_row(line: str) -> dict[str, Any] | None:
    """The point stored on ``line``, or None for anything else."""
    try:
        row = json.loads(line)
    except ValueError:
        return None
    if not isinstance(row, dict) or not all(isinstance(row.get(k), t) for k, t in ROW_FIELDS.items()):
        return None
    return row if row["status"] in ("ok", "failed") and len(row["key"]) == 64 else None


def metric(row: dict[str, Any], key: str, joint: int | None = None) -> Any:
    value = (row.get("summary") or {}).get(key)
    if joint is not None:
        value = None if value is None else value[joint]
    return value


def tail_error(row: dict[str, Any]) -> float | None:
    """Post-transient tracking error: max over both joints of max |e| over the run's second half."""
    values = metric(row, "max_abs_error_last_half")
    if row["status"] != "ok" or not values or any(v is None for v in values):
        return None
    return max(values)


class SweepStore:
    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.jsonl = self.folder / "points.jsonl"

    def load(self) -> dict[str, dict[str, Any]]:
        """Stored rows by key (the last line of a key wins). A line that is not a stored point (torn by
        a crash, edited, foreign) is reported on stderr and skipped, so that point runs again."""
        rows: dict[str, dict[str, Any]] = {}
        self.skipped_lines: list[int] = []
        if self.jsonl.is_file():
            for number, line in enumerate(self.jsonl.read_text(errors="replace").splitlines(), start=1):
                row = _stored_row(line)
                if row is None:
                    self.skipped_lines.append(number)
                else:
                    rows[row["key"]] = row
        if self.skipped_lines:
            print(f"sotc-cosim: {self.jsonl}: skipped {len(self.skipped_lines)} line(s) that are not stored points "
                  f"(line {', '.join(map(str, self.skipped_lines[:5]))}); those points run again", file=sys.stderr)
        return rows

    def _repair_tail(self) -> None:
        """A last line without its newline (a crash while appending) gets one, so that the next row
        starts on a line of its own."""
        try:
            with open(self.jsonl, "rb+") as f:
                if f.seek(0, os.SEEK_END) and (f.seek(-1, os.SEEK_END), f.read(1))[1] != b"\n":
                    f.write(b"\n")
        except FileNotFoundError:
            pass
        except OSError as exc:
            raise OutputError.of(self.jsonl, exc) from None

    def begin(self, sweep: Sweep, keys: list[str]) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        self.sweep, self.keys = sweep, keys
        self._repair_tail()
        self.stored = self.load()
        self.table_written = 0.0

    def add(self, row: dict[str, Any]) -> None:
        """Store one finished point: its trace and recording, then its line (flushed, fsynced)."""
        trace, rrd = row.pop("trace", None), row.pop("rrd", None)
        short = row["key"][:16]
        if trace is not None and len(trace):
            (self.folder / "traces").mkdir(exist_ok=True)
            np.save(self.folder / "traces" / f"{short}.npy", trace)
        if rrd is not None:
            (self.folder / "points").mkdir(exist_ok=True)
            (self.folder / "points" / f"{short}.rrd").write_bytes(rrd)
            row["recording"] = f"points/{short}.rrd"
        try:
            with open(self.jsonl, "a") as f:
                f.write(json.dumps(row, sort_keys=True, allow_nan=False) + "\n")
                f.flush()
                os.fsync(f.fileno())
        except OSError as exc:
            raise OutputError.of(self.jsonl, exc) from None
        self.stored[row["key"]] = row
        if time.monotonic() - self.table_written > TABLE_INTERVAL_S:  # the table follows, at most once a second
            self.write_table()

    def rows(self) -> list[dict[str, Any]]:
        """The stored rows of this sweep's points, by index (each with its current index)."""
        return [{**self.stored[key], "index": index} for index, key in enumerate(self.keys) if key in self.stored]

    def write_table(self) -> Path:
        path = self.folder / "points.csv"
        atomic_write(path, table_csv(self.sweep, self.rows()))
        self.table_written = time.monotonic()
        return path

    def traces(self) -> list[tuple[str, np.ndarray]]:
        out = []
        for row in self.rows():
            path = self.folder / "traces" / f"{row['key'][:16]}.npy"
            if path.is_file():
                out.append((f"{row['index']:04d}", np.load(path)))
        return out


def _cell(value: Any) -> str:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else str(value)


def table_csv(sweep: Sweep, rows: list[dict[str, Any]]) -> str:
    labels = [a.label for a in sweep.axes]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    columns = table_metrics(sweep)
    writer.writerow(["index", "key", *labels, "status", "reason", *(c for c, _, _ in columns)])
    for r in rows:
        # a failed point's partial metrics depend on where it stopped (a time limit): left blank
        metrics = [_cell(metric(r, k, j)) if r["status"] == "ok" else "" for _, k, j in columns]
        reason = " ".join((r.get("reason") or "").split())
        writer.writerow([r["index"], r["key"][:16], *(_cell(r["settings"].get(lb)) for lb in labels), r["status"],
                         reason, *metrics])
    return buf.getvalue()


# --- aggregates ----------------------------------------------------------------------------------

def _value_text(value: Any) -> str:
    if isinstance(value, tuple):
        return ", ".join(_value_text(v) for v in value)
    return value if isinstance(value, str) else format(value, ".4g")


def _controller(row: dict[str, Any]) -> str:
    """The point's controller axis value (an FMU or a named entry), else the FMU its summary names."""
    return str(row["settings"].get("controller") or metric(row, "controller") or "")


def _group_value(row: dict[str, Any], axes: list[Axis]) -> Any:
    values = tuple(row["settings"][a.label] for a in axes)
    return values[0] if len(values) == 1 else values


def group_rows(sweep: Sweep, rows: list[dict[str, Any]], axes: list[Axis]) -> list[tuple[str, str, list[dict[str, Any]]]]:
    """(value, controller, rows) for every value of a combination axis (a group of axes varied
    together) that some point sets, split by controller when the sweep also has a controller axis;
    a single random axis with many values goes in 4 equal bins."""
    split = any(a.name == "controller" for a in sweep.axes) and axes[0].name != "controller"
    present = [r for r in rows if axes[0].label in r["settings"]]
    values = sorted({_group_value(r, axes) for r in present}, key=lambda v: (isinstance(v, str), v))
    if len(values) > 8 and all(isinstance(v, float) for v in values):
        edges = np.linspace(values[0], values[-1], 5)
        bins = [(f"[{edges[i]:.4g}, {edges[i + 1]:.4g}{']' if i == 3 else ')'}",
                 lambda v, i=i: edges[i] <= v < edges[i + 1] or (i == 3 and v == edges[4])) for i in range(4)]
    else:
        bins = [(_value_text(v), lambda x, v=v: x == v) for v in values]
    controllers = sorted({_controller(r) for r in present}) if split else [""]
    out = []
    for text, member in bins:
        for ctrl in controllers:
            chosen = [r for r in present if member(_group_value(r, axes)) and (not split or _controller(r) == ctrl)]
            if chosen:
                out.append((text, ctrl, chosen))
    return out


def _per_controller_text(sweep: Sweep) -> str:
    """The sentence on ``controller_settings``: what each controller FMU's points get, and why."""
    if not sweep.per_controller:
        return ""
    parts = []
    for fmu, sets in sweep.controller_parameters().items():
        entry = sweep.per_controller[fmu]
        seed = "the first tuning seed" if entry.tuning_seed is None else f"tuning seed {entry.tuning_seed}"
        how = (f"the best point of its tuning search (`orchestration.study.tuning`, {seed}) under the "
               "point's limit handling, " if entry.tuning == "best" else "")
        values = " or ".join(", ".join(f"`{k} = {v:g}`" for k, v in params.items()) for params in sets)
        parts.append(f"{fmu}: {how}{values or 'no point'}")
    return " Per controller (`controller_settings`): " + "; ".join(parts) + "."


DOC_ROWS = 20  # a docs page lists an axis of single points up to this many rows; beyond, its CSV holds them


def summary_markdown(sweep: Sweep, rows_all: list[dict[str, Any]], total: int, heading: str = "#",
                     points_file: str | None = None) -> str:
    """The sweep's summary, a table per axis group; with ``points_file`` (a docs page's block), a long group
    (over ``DOC_ROWS`` rows) whose every row is one point is not listed again but named by that file, which
    holds every point."""
    ok = [r for r in rows_all if r["status"] == "ok"]
    lines = [f"{heading} Sweep `{sweep.name}`", "", sweep.description, "",
             f"{len(rows_all)} of {total} points stored, {len(ok)} ok, {len(rows_all) - len(ok)} failed; base scenario "
             f"`{sweep.base.name}`, {sweep.combine} combination, seed {sweep.seed}, stop time {sweep.base.stop_time:g} s "
             "(unless an axis sets it). Post-transient error = max over both joints of max |e| over the second "
             "half of the run; max ||tau|| against the torque limit rho; a failed point counts in 'failed' only."
             + (" Set for every point: " + ", ".join(f"`{k} = {v:g}`" for k, v in sweep.fixed.items()) + "." if sweep.fixed else "")
             + _per_controller_text(sweep),
             ""]
    header = ["value", "controller", "points", "failed", "mean post-transient max abs e [rad]", "std", "worst",
              "worst max norm tau [N.m]", "samples over limit"]
    for group, axes in sweep.groups().items():
        title = f"`{axes[0].label}`" if len(axes) == 1 else f"{group} ({', '.join(f'`{a.label}`' for a in axes)})"
        rows = []
        grouped = group_rows(sweep, rows_all, axes)
        if points_file and len(grouped) > DOC_ROWS and all(len(chosen) == 1 for _, _, chosen in grouped):
            lines += [f"{heading}# Axis {title}", "", f"One row per point ({len(grouped)} rows), not repeated "
                      f"here: every point's settings and metrics are in [{Path(points_file).name}]({points_file}).", ""]
            continue
        for text, ctrl, chosen in grouped:
            tails = [t for t in (tail_error(r) for r in chosen) if t is not None]
            taus = [metric(r, "max_norm_tau") for r in chosen if r["status"] == "ok" and metric(r, "max_norm_tau") is not None]
            over = sum(metric(r, "samples_over_limit") or 0 for r in chosen if r["status"] == "ok")
            failed = sum(r["status"] != "ok" for r in chosen)
            rows.append([text, ctrl or "-", len(chosen), failed, number(float(np.mean(tails)) if tails else None, ".3g"),
                         number(float(np.std(tails)) if tails else None, ".3g"), number(max(tails) if tails else None, ".3g"),
                         number(max(taus) if taus else None), over])
        lines += [f"{heading}# Axis {title}", "", table(header, rows, align="llrrrrrrr"), ""]
    failed = [r for r in rows_all if r["status"] != "ok"]
    if failed:
        rows = [[r["index"], ", ".join(f"{k} = {_value_text(v)}" for k, v in sorted(r["settings"].items())),
                 " ".join((r.get("reason") or "").split())[:300]] for r in failed]
        lines += [f"{heading}# Failed points", "", table(["index", "settings", "reason"], rows, align="rll"), ""]
    return "\n".join(lines)


def plot_name(group: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in group) + ".png"


def write_plots(sweep: Sweep, rows: list[dict[str, Any]], folder: Path) -> list[Path]:
    """Per combination axis: post-transient max |e| (log scale) and max ||tau|| per point, by
    controller; a group of axes is plotted against its draw number (its values: summary.md)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    rho = sweep.base.torque_limit()
    written = []
    for group, axes in sweep.groups().items():
        present = [r for r in rows if axes[0].label in r["settings"]]
        if not present:
            continue
        values = sorted({_group_value(r, axes) for r in present}, key=lambda v: (isinstance(v, str), v))
        categorical = len(axes) > 1 or isinstance(values[0], str)
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        for n, ctrl in enumerate(sorted({_controller(r) for r in present})):
            mine = [r for r in present if _controller(r) == ctrl]
            x = [values.index(_group_value(r, axes)) if categorical else _group_value(r, axes) for r in mine]
            ok = [(xi, r) for xi, r in zip(x, mine) if tail_error(r) is not None]
            top.plot([xi for xi, _ in ok], [tail_error(r) for _, r in ok], "o", color=f"C{n}", label=ctrl, alpha=0.8)
            bottom.plot([xi for xi, _ in ok], [metric(r, "max_norm_tau") for _, r in ok], "o", color=f"C{n}", alpha=0.8)
            bad = [xi for xi, r in zip(x, mine) if r["status"] != "ok"]
            if bad:
                top.plot(bad, [1.0] * len(bad), "x", color=f"C{n}", markersize=10, label=f"{ctrl}: failed")
        top.set_yscale("log")
        top.set_ylabel("post-transient max |e| [rad]")
        bottom.axhline(rho, color="grey", linestyle="--", label=f"rho = {rho:g} N.m")
        bottom.set_ylabel("max ||tau|| [N.m]")
        short = len(axes) <= 3  # a few axes: their values label the ticks; more: the draw number
        bottom.set_xlabel(axes[0].label if len(axes) == 1 else
                          f"{group}: " + (", ".join(a.label for a in axes) if short else "draw (values in summary.md)"))
        if categorical:
            bottom.set_xticks(range(len(values)), [_value_text(v) if short else str(i + 1) for i, v in enumerate(values)],
                              rotation=15)
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
        top.set_title(f"sweep {sweep.name}: {group}")
        fig.tight_layout()
        path = folder / plot_name(group)
        with atomic_file(path, "wb") as f:
            fig.savefig(f, dpi=80, format="png")
        plt.close(fig)
        written.append(path)
    return written


def write_reports(store: SweepStore, total: int) -> dict[str, Path]:
    """Every report of the folder from what is stored: table, summary, plots, sweep recording."""
    sweep, rows = store.sweep, store.rows()
    out = {"table": store.write_table()}
    out["summary"] = store.folder / "summary.md"
    atomic_write(out["summary"], summary_markdown(sweep, rows, total) + "\n")
    write_plots(sweep, rows, store.folder / "plots")
    out["plots"] = store.folder / "plots"
    traces = store.traces()
    if traces:
        from orchestration.recording.overlays import record_sweep

        step = min(p.scenario.step_size for p in sweep.points())
        out["recording"] = record_sweep(traces, step, store.folder / "sweep.rrd", f"sweep {sweep.name}: tracking errors")
    return out


# --- generated blocks in docs (orchestration.reports.docgen checks them) ---------------------------------

def doc_block(sweep: Sweep, rows: list[dict[str, Any]], total: int, plots: list[str]) -> str:
    body = summary_markdown(sweep, rows, total, heading="###", points_file=f"sweeps/{sweep.name}/points.csv")
    images = "\n".join(f"![{Path(p).stem}]({p})" for p in plots)
    return f"{body}\n{images}\n"


def _doc_plots(sweep: Sweep) -> list[str]:
    return [f"sweeps/{sweep.name}/{plot_name(group)}" for group in sweep.groups()]


def stored_rows(name: str, docs: Path) -> tuple[Sweep, list[dict[str, Any]]]:
    """Shipped sweep ``name`` and the rows its last ``--doc`` run stored under ``docs``."""
    from orchestration.sweep.spec import load_sweep

    rows = [json.loads(line) for line in (docs / "sweeps" / name / "points.jsonl").read_text().splitlines()]
    return load_sweep(name), rows


def stored_sweep_block(name: str, docs: Path) -> str:
    """The block of shipped sweep ``name`` from the rows its last ``--doc`` run stored under ``docs``."""
    sweep, rows = stored_rows(name, docs)
    return doc_block(sweep, rows, len(sweep.points()), _doc_plots(sweep))


def paired_tail_errors(rows: list[dict[str, Any]]) -> dict[str, dict[tuple, float | None]]:
    """Controller -> {the point's other axis settings: its post-transient error}: the controllers of a
    sweep with a controller axis, each over the same points (None: the point failed)."""
    out: dict[str, dict[tuple, float | None]] = {}
    for r in rows:
        where = tuple(sorted((k, v) for k, v in r["settings"].items() if k.partition(".")[0] != "controller"))
        out.setdefault(_controller(r), {})[where] = tail_error(r)
    return out


def write_doc(store: SweepStore, total: int, doc: Path) -> Path:
    """Write the sweep's results into ``doc``'s block ``generated:sweep-<name>``; the plots and the
    stored rows go to ``sweeps/<name>/`` beside it (the rows let docgen check the block)."""
    import shutil

    doc = Path(doc)
    sweep, rows = store.sweep, store.rows()
    folder = doc.parent / "sweeps" / sweep.name
    folder.mkdir(parents=True, exist_ok=True)
    write_plots(sweep, rows, folder)
    shutil.copyfile(store.folder / "points.csv", folder / "points.csv")
    atomic_write(folder / "points.jsonl", "".join(json.dumps(r, sort_keys=True) + "\n" for r in rows))
    text = doc.read_text() if doc.is_file() else f"# {doc.stem}\n"
    atomic_write(doc, replace_block(text, f"sweep-{sweep.name}", doc_block(sweep, rows, total, _doc_plots(sweep))))
    return doc
