"""Progress of long commands (sweeps, ``reproduce``): done, failed, running, estimated time left.

On a terminal: a tqdm bar. Otherwise (a pipe, a log file, CI): one plain line per finished item,
so the output stays readable and greppable.
"""
from __future__ import annotations

import shutil
import sys
import time
from typing import TextIO


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}" if seconds >= 3600 else f"{seconds // 60}:{seconds % 60:02d}"


class Progress:
    """``update`` after each finished item; ``close`` at the end. ``skipped`` items (e.g. resumed
    from disk) count as done but not in the time estimate."""

    def __init__(self, total: int, label: str, workers: int = 1, skipped: int = 0, skipped_failed: int = 0,
                 stream: TextIO | None = None):
        self.total, self.label, self.workers = total, label, max(1, workers)
        self.done, self.failed, self.skipped = skipped, skipped_failed, skipped
        self.stream = stream or sys.stdout
        self.started = time.monotonic()
        self.bar = None
        if self.stream.isatty():
            from tqdm import tqdm

            # a terminal that reports no size (some ptys) would hide the bar: fall back to 100 x 24
            size = shutil.get_terminal_size(fallback=(100, 24))
            self.bar = tqdm(total=total, initial=skipped, desc=label, unit="pt", file=self.stream,
                            ncols=size.columns or 100, nrows=size.lines or 24)

    def eta(self) -> float | None:
        computed = self.done - self.skipped
        if computed == 0:
            return None
        return (time.monotonic() - self.started) / computed * (self.total - self.done)

    def running(self) -> int:
        return min(self.workers, self.total - self.done)

    def update(self, ok: bool, note: str = "") -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        if self.bar is not None:
            self.bar.set_postfix_str(f"failed {self.failed}, running {self.running()}", refresh=False)
            self.bar.update(1)
            return
        print(f"{self.label}: {self.done}/{self.total} done, {self.failed} failed, {self.running()} running, "
              f"about {_clock(self.eta())} left" + (f" | {note}" if note else ""), file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
