"""The instruments of the speed bench's cost split: a timer around callables, a temporary attribute
patch, and the cores timed where the loaded FMUs run them."""
from __future__ import annotations

import contextlib
import functools
import sys
import time


class Timer:
    """Adds up the time spent in wrapped callables, and their calls, per label. The wrapper's own work
    outside its two clock readings (its frame, the sum, the count) lands in the caller's share, a little
    inside them in its own: both are measured (``wrapper_cost``) and taken out by the cost split. It is
    kept to a minimum (no keyword arguments, the clock and the tables as locals)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}

    def wrap(self, label: str, fn):
        seconds, calls, clock = self.seconds, self.calls, time.perf_counter
        seconds.setdefault(label, 0.0)
        calls.setdefault(label, 0)

        def timed(*args):
            t0 = clock()
            try:
                return fn(*args)
            finally:
                seconds[label] += clock() - t0
                calls[label] += 1
        return timed


@functools.cache
def wrapper_cost(rounds: int = 7, n: int = 200_000) -> tuple[float, float]:
    """Seconds one ``Timer`` wrapper adds per call (measured once per process, on a method that does
    nothing, the fastest of ``rounds`` loops of ``n`` calls each): (to its caller's share, outside its
    clock readings; to its own label, inside them beyond the bare call)."""
    class Probe:
        def call(self) -> None:
            return None

    def loop(fn) -> float:
        t0 = time.perf_counter()
        if fn is None:  # the loop alone
            for _ in range(n):
                pass
        else:
            for _ in range(n):
                fn()
        return (time.perf_counter() - t0) / n

    def timed_round(timer: Timer) -> tuple[float, float]:  # (per call in all, per call inside the clock)
        timer.seconds["probe"] = 0.0
        wall = loop(probe.call)
        return wall, timer.seconds["probe"] / n

    probe, timer = Probe(), Timer()
    empty = min(loop(None) for _ in range(rounds))
    bare = min(loop(probe.call) for _ in range(rounds)) - empty  # the call, which its label holds
    with patched(Probe, "call", timer.wrap("probe", Probe.call)):
        wrapped, inside = min(timed_round(timer) for _ in range(rounds))  # the fastest round, both figures
    own = max(inside - bare, 0.0)
    return max(wrapped - empty - bare - own, 0.0), own


@contextlib.contextmanager
def patched(obj, name: str, value):
    old = getattr(obj, name)
    setattr(obj, name, value)
    try:
        yield
    finally:
        setattr(obj, name, old)


@contextlib.contextmanager
def hosted_cores(timer: Timer):
    """Time the cores where the FMUs run them: the FMUs' bundled copies of ``SotcCore.evaluate``,
    ``SotcCore.advance``, ``integrate`` (the plant step) and ``CircleTrajectory.sample``, found in ``sys.modules``
    once the FMUs were loaded (pythonfmu keeps their modules; each instantiation re-runs the FMU
    script, which imports the wrapped ``integrate``)."""
    # (name, method or None for a function, the module it must come from, bundled copies included)
    labels = {("SotcCore", "evaluate", "fmu_controller.sotc"): "controller evaluate",
              ("SotcCore", "advance", "fmu_controller.sotc"): "controller learn",
              ("CircleTrajectory", "sample", "fmu_plant.trajectory"): "reference",
              ("integrate", None, "fmu_plant.dynamics"): "plant step"}
    undo, wrapped, wrappers = [], {}, set()
    for module in list(sys.modules.values()):
        space = getattr(module, "__dict__", {})
        for (name, method, home), label in labels.items():
            obj = space.get(name)
            owner, attr = (obj, method) if method else (module, name)
            if not str(getattr(obj, "__module__", "")).endswith(home) or (method and not isinstance(obj, type)):
                continue
            original = getattr(owner, attr)
            if id(original) in wrappers:
                continue  # the same class or function seen through another module: timed already
            if id(original) not in wrapped:
                wrapped[id(original)] = timer.wrap(label, original)
                wrappers.add(id(wrapped[id(original)]))
            undo.append((owner, attr, original))
            setattr(owner, attr, wrapped[id(original)])
    if not any(owner.__name__ == "SotcCore" for owner, _, _ in undo if isinstance(owner, type)):
        raise RuntimeError("the speed bench found no SotcCore in the loaded FMUs' modules")
    try:
        yield
    finally:
        for owner, attr, original in reversed(undo):
            setattr(owner, attr, original)
