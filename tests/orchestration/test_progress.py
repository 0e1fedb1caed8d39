"""The plain progress lines of a long command in a log: a few, not one per item (``tune`` wrote 4,600
lines for 3 searches), and a time left from this command's own items (after a resume it read 13:22:09
for a run that took 25 minutes). The clock is the test's own: nothing here waits."""
from __future__ import annotations

import io

from orchestration.progress import INTERVAL_S, Progress


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_a_log_gets_a_line_per_interval_the_failures_and_the_last():
    clock, out = _Clock(), io.StringIO()
    progress = Progress(200, "tune", stream=out, clock=clock)
    step = INTERVAL_S / 10  # ten items per interval
    for i in range(200):
        clock.now = i * step
        progress.update(i != 57, f"item {i}")
    lines = out.getvalue().splitlines()
    shown = [int(line.rsplit(" ", 1)[1]) for line in lines]
    assert shown[0] == 0 and shown[-1] == 199 and 57 in shown  # the first, the last, the failure
    assert len(lines) == 200 // 10 + 2  # one per interval: 0, 10, 20, ..., 190, and 57 and 199
    assert all(b - a >= 10 or 57 in (a, b) for a, b in zip(shown, shown[1:-1]))


def test_the_time_left_counts_only_this_commands_items_from_the_first_on():
    clock, out = _Clock(), io.StringIO()
    progress = Progress(1000, "tune", workers=2, skipped=900, stream=out, clock=clock)
    clock.now = 600.0  # ten minutes of starting, reading the journal, replaying, before the first trial
    progress.update(True)
    assert "about ? left" in out.getvalue().splitlines()[-1]  # one item gives no pace yet
    for k in range(1, 11):  # then one trial every 2 s
        clock.now = 600.0 + 2 * k
        progress.update(True)
    assert progress.eta() == 2.0 * (1000 - 911)  # 2 s per trial for the 89 left, not hours
    # the last line printed (at trial 910, 18 s after the first: 9 gaps of 2 s) says so too
    assert out.getvalue().splitlines()[-1] == "tune: 910/1000 done, 0 failed, 2 running, about 3:00 left"
