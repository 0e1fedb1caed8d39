"""What a recording holds, read back with Rerun's own reader: the tests of the recordings compare these."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader


def read_entities(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """Per temporal entity: its steps, sim_time (int ns) and components, rows sorted by step."""
    parts: dict[str, list[pa.RecordBatch]] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if not chunk.is_static:
            parts.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    out = {}
    for entity, batches in parts.items():
        table = pa.Table.from_batches([b.drop_columns(["rerun.controls.RowId"]) for b in batches]).combine_chunks()
        cols = {name: table.column(name) for name in table.column_names}
        order = np.argsort(cols["step"].to_numpy(), kind="stable")
        out[entity] = {
            "step": cols.pop("step").to_numpy()[order],
            "sim_time": cols.pop("sim_time").cast(pa.int64()).to_numpy()[order],
            **{name: [col[int(i)].as_py() for i in order] for name, col in cols.items()},
        }
    return out


def statics(path: Path) -> dict[str, dict[str, list]]:
    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static:
            rb = chunk.to_record_batch()
            out.setdefault(chunk.entity_path, {}).update(
                {n: rb.column(n).to_pylist() for n in rb.schema.names if n not in ("rerun.controls.RowId", "RecordingInfo:start_time")})
    return out
