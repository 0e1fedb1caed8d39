"""Progress of long commands (sweeps, ``reproduce``, ``tune``): done, failed, running, estimated time left;
``stage`` for a command whose long steps are few and unlike (``bench``).

On a terminal: a tqdm bar. Otherwise (a pipe, a log file, CI): plain lines, so the output stays readable
and greppable: one for the first item, one for the last, one for every failure, and between them at most
one per ``INTERVAL_S`` (a log of ``tune`` had a line per trial: 4,600 for 3 searches).

The time left is estimated from the items finished by this command, from the first of them on: not from
its start (the cluster starting, the journal read, a resumed search replayed: after a resume it read
13:22:09 for a run that took 25 minutes) and not from the items found done before (``skipped``).
"""
from __future__ import annotations

import shutil
import sys
import time
from typing import Callable, TextIO

INTERVAL_S = 5.0  # seconds between two plain lines at least (failures and the last item aside)


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}" if seconds >= 3600 else f"{seconds // 60}:{seconds % 60:02d}"


class Progress:
    """``update`` after each finished item; ``close`` at the end. ``skipped`` items (e.g. resumed
    from disk) count as done but not in the time estimate. ``clock``: seconds, monotonic."""

    def __init__(self, total: int, label: str, workers: int = 1, skipped: int = 0, skipped_failed: int = 0,
                 stream: TextIO | None = None, clock: Callable[[], float] = time.monotonic):
        self.total, self.label, self.workers = total, label, max(1, workers)
        self.done, self.failed, self.skipped = skipped, skipped_failed, skipped
        self.stream = stream or sys.stdout
        self.clock = clock
        self.first: float | None = None  # when this command's first item finished
        self.last: float | None = None  # ... and its latest
        self.printed: float | None = None  # when the last plain line was printed (failures aside)
        self.bar = None
        if self.stream.isatty():
            from tqdm import tqdm

            # a terminal that reports no size (some ptys) would hide the bar: fall back to 100 x 24
            size = shutil.get_terminal_size(fallback=(100, 24))
            self.bar = tqdm(total=total, initial=skipped, desc=label, unit="pt", file=self.stream,
                            ncols=size.columns or 100, nrows=size.lines or 24)

    def eta(self) -> float | None:
        """Seconds left at the pace of this command's items since its first one (None before two)."""
        computed = self.done - self.skipped
        if computed < 2:
            return None
        return (self.last - self.first) / (computed - 1) * (self.total - self.done)

    def running(self) -> int:
        return min(self.workers, self.total - self.done)

    def update(self, ok: bool, note: str = "") -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        self.last = self.clock()
        self.first = self.last if self.first is None else self.first
        if self.bar is not None:
            self.bar.set_postfix_str(f"failed {self.failed}, running {self.running()}", refresh=False)
            self.bar.update(1)
            return
        if ok and self.done < self.total:  # a failure and the last item always get their line
            if self.printed is not None and self.last - self.printed < INTERVAL_S:
                return
            self.printed = self.last
        print(f"{self.label}: {self.done}/{self.total} done, {self.failed} failed, {self.running()} running, "
              f"about {_clock(self.eta())} left" + (f" | {note}" if note else ""), file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def stage(label: str, what: str) -> None:
    """A line on stderr as one long step of a command starts (its report stays alone on stdout)."""
    print(f"{label}: {what} ...", file=sys.stderr, flush=True)
