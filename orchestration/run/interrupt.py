"""Ctrl-C that stops a run between two steps instead of in the middle of an FMU call.

Python's default SIGINT handler raises KeyboardInterrupt at the next bytecode, and with pythonfmu
that bytecode is as likely to be inside an FMU's Python callback as in the master: the exception
then leaves an FMI call, pythonfmu's binary releases references it does not own, and the host dies
later with a segfault. So the commands run with ``sigint_deferred()``: SIGINT only sets a flag; the
master looks at it after every step, stops, terminates and frees every instance, finalises the
recording and returns a result marked ``interrupted``; the CLI starts no further work, keeps what
finished, and exits with ``exit_codes.INTERRUPTED`` (128 + SIGINT), the shell's convention.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator


class Interrupted(Exception):
    """Raised by the CLI's own code (never inside an FMU call) to unwind once SIGINT was seen."""


class _State:
    requested = False


STATE = _State()


def requested() -> bool:
    return STATE.requested


def check() -> None:
    """Raise Interrupted if SIGINT was seen: call between units of work, never inside an FMU call."""
    if STATE.requested:
        raise Interrupted("interrupted by SIGINT")


def _note(signum, frame) -> None:
    STATE.requested = True


@contextmanager
def sigint_deferred() -> Iterator[None]:
    """While active (main thread only), SIGINT sets ``STATE.requested`` instead of raising."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, _note)
    STATE.requested = False
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
