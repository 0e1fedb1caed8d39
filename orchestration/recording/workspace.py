"""The frame of the workspace views (paper Figs 9 and 12): a 0.5 m grid, the axes through the arm's
base with their ticks in metres, the base itself and a legend, logged once, static, at ``FRAME``.
Rerun's 2D view has no axes of its own. Coordinates are the workspace's (metres, +y up): the views
mirror ``/workspace`` (``MIRROR``) because Rerun draws +y downwards."""
from __future__ import annotations

from typing import Sequence

import numpy as np
import rerun as rr

FRAME = "/workspace/frame"
MIRROR = rr.Transform3D(scale=[1.0, -1.0, 1.0])
GRID = np.arange(0.0, 2.01, 0.5)  # m: the grid lines and the ticks of both axes
X_END, Y_END, LOW = 2.1, 1.6, -0.25  # m: where the axes and the grid end
LEGEND_Y, LEGEND_X = 1.82, (0.25, 2.15)  # m: the legend's row (a line above each label) and its width
GRID_COLOR, AXIS_COLOR, TEXT_COLOR = (225, 225, 225), (110, 110, 110), (60, 60, 60)
BASE_COLOR = (30, 30, 30)


def send_frame(stream: rr.RecordingStream, legend: Sequence[tuple[str, tuple[int, ...]]], mirror: bool) -> None:
    """Grid, axes, ticks, base and the legend (a short line above each label); ``mirror``: also log the
    mirror at ``/workspace`` (a comparison, whose runs are mirrored under their own prefix)."""
    if mirror:
        stream.log("/workspace", MIRROR, static=True)
    lines = [[(x, LOW), (x, Y_END)] for x in GRID] + [[(LOW, y), (X_END, y)] for y in GRID[1:-1]]
    stream.log(f"{FRAME}/grid", rr.LineStrips2D(lines, colors=[GRID_COLOR], radii=[0.003], draw_order=1.0), static=True)
    stream.log(f"{FRAME}/axes", rr.LineStrips2D([[(LOW, 0.0), (X_END, 0.0)], [(0.0, LOW), (0.0, Y_END)]],
                                                colors=[AXIS_COLOR], radii=[0.005], draw_order=2.0), static=True)
    # a label is drawn centred on its point (radius 0)
    ticks = [(x, -0.09) for x in GRID[1:]] + [(-0.13, y) for y in GRID[1:-1]] + [(X_END - 0.05, 0.09), (0.0, Y_END + 0.07)]
    labels = [f"{v:g}" for v in GRID[1:]] + [f"{v:g}" for v in GRID[1:-1]] + ["X [m]", "Y [m]"]
    stream.log(f"{FRAME}/ticks", rr.Points2D(ticks, labels=labels, radii=[0.0], colors=[TEXT_COLOR], show_labels=True),
               static=True)
    stream.log(f"{FRAME}/base", rr.Points2D([(0.0, 0.0)], labels=["base (0, 0)"], radii=[0.045], colors=[BASE_COLOR],
                                            show_labels=True, draw_order=50.0), static=True)
    width = (LEGEND_X[1] - LEGEND_X[0]) / max(len(legend), 1)
    centres = LEGEND_X[0] + width * (np.arange(len(legend)) + 0.5)
    stream.log(f"{FRAME}/legend", rr.LineStrips2D([[(x - 0.12, LEGEND_Y), (x + 0.12, LEGEND_Y)] for x in centres],
                                                  colors=[c for _, c in legend], radii=[0.012]), static=True)
    stream.log(f"{FRAME}/legend/labels", rr.Points2D([(x, LEGEND_Y - 0.09) for x in centres], labels=[t for t, _ in legend],
                                                     radii=[0.0], colors=[TEXT_COLOR], show_labels=True), static=True)
