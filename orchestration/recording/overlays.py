"""Recordings that overlay several runs: ``record_comparison`` (paper Figs 10-12, one ``/<scenario>/``
subtree per finished run) and ``record_sweep`` (the tracking errors of every point of a sweep)."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import rerun as rr

from orchestration.recording.blueprint import comparison_blueprint, sweep_blueprint
from orchestration.recording.rrd_file import RecordingFile
from orchestration.recording.workspace import send_frame
from orchestration.recording.writer import (
    COMPARE_BLOCK,
    DESIRED,
    LIMIT,
    PALETTE,
    RunWriter,
    comparison_groups,
    send_result_properties,
    send_scenario_properties,
    send_view_properties,
    step_nanos,
    time_columns,
)
from orchestration.run.master import RunResult


def record_sweep(traces: Sequence[tuple[str, np.ndarray]], step_size: float, path: str | Path, title: str) -> Path:
    """One file overlaying the tracking errors of every point of a sweep: ``/points/<label>/e1``
    and ``.../e2``, each trace an array (m, 3) of [t, e1, e2] (thinned samples of a run)."""
    path = Path(path)
    rec = RecordingFile(path, sweep_blueprint())
    stream = rec.stream
    try:
        stream.send_recording_name(title)
        ns = step_nanos(step_size)
        for n, (label, trace) in enumerate(traces):
            if not len(trace):
                continue
            color = PALETTE[1:][n % (len(PALETTE) - 1)]
            steps = np.round(trace[:, 0] / step_size).astype(np.int64)
            for j in (1, 2):
                entity = f"/points/{label}/e{j}"
                stream.log(entity, rr.SeriesLines(names=[f"{label}: e{j} [rad]"], colors=[color]), static=True)
                stream.send_columns(entity, time_columns(steps, ns), rr.Scalars.columns(scalars=trace[:, j]))
    except BaseException:
        rec.close()
        raise
    rec.close()
    return path


# --- comparison ---------------------------------------------------------------------------------

def _labels(results: Sequence[RunResult]) -> list[str]:
    labels, seen = [], {}
    for r in results:
        base = r.scenario.name.replace("/", "_")
        seen[base] = seen.get(base, 0) + 1
        labels.append(base if seen[base] == 1 else f"{base}-{seen[base]}")
    return labels


def record_comparison(results: Sequence[RunResult], path: str | Path) -> Path:
    """One file with the runs overlaid (paper Figs 10-12): ``/<scenario>/...`` per run."""
    if not results:
        raise ValueError("record_comparison needs at least one run")
    path = Path(path)
    labels = _labels(results)
    runs_palette = PALETTE[1:]  # PALETTE[0] is a blue like DESIRED: keep blue for the desired path alone
    colors = [runs_palette[i % len(runs_palette)] for i in range(len(results))]
    columns = [{inst: list(out) for inst, out in r.outputs.items()} for r in results]
    rho = max(r.scenario.torque_limit() for r in results)
    writers = [RunWriter(r.scenario, cols, comparison_groups(f"/{label}", label, color), prefix=f"/{label}", arm_color=color)
               for r, label, color, cols in zip(results, labels, colors, columns)]
    rec = RecordingFile(path, comparison_blueprint(labels, writers))
    stream = rec.stream
    try:
        stream.send_recording_name("compare: " + ", ".join(labels))
        send_view_properties(stream)
        if any(w.has_arm or w.has_target for w in writers):
            send_frame(stream, [(label, color) for label, color, w in zip(labels, colors, writers) if w.has_arm]
                       + [("E_d: desired path (47)", DESIRED)] * any(w.has_target for w in writers), mirror=True)
        for r, label, writer in zip(results, labels, writers):
            send_scenario_properties(stream, r.scenario, r.parameters, prefix=f"{label}_", fmus=r.fmus)
            send_result_properties(stream, r, prefix=f"{label}_")
            writer.stream = stream
            writer.send_static()
            rows = {inst: np.column_stack([r.outputs[inst][v] for v in names]) if names else np.empty((r.samples, 0))
                    for inst, names in writer.columns.items()}
            for lo in range(0, r.samples, COMPARE_BLOCK):
                writer.send_block({inst: a[lo:lo + COMPARE_BLOCK] for inst, a in rows.items()})
            writer.send_end(r)
        longest = max(results, key=lambda r: r.samples)
        if longest.samples:
            steps = np.arange(longest.samples, dtype=np.int64)
            ns = step_nanos(longest.scenario.step_size)
            stream.log("/limit", rr.SeriesLines(names=[f"+rho = {rho:g} N.m", f"-rho = {-rho:g} N.m"],
                                                colors=[LIMIT, LIMIT]), static=True)
            limits = np.tile([rho, -rho], (len(steps), 1))
            stream.send_columns("/limit", time_columns(steps, ns), rr.Scalars.columns(scalars=limits))
    except BaseException:
        rec.close()
        raise
    rec.close()
    return path
