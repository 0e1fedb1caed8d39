"""Ctrl-C, SIGTERM and SIGHUP stop a run between two steps instead of in the middle of an FMU call.

Python's default SIGINT handler raises KeyboardInterrupt at the next bytecode, and with pythonfmu
that bytecode is as likely to be inside an FMU's Python callback as in the master: the exception
then leaves an FMI call, pythonfmu's binary releases references it does not own, and the host dies
later with a segfault; SIGTERM and SIGHUP (what batch systems, containers, CI and a closed terminal
send) kill the process at once, leaving a recording without its footer and temporary folders behind.
So the commands run with ``signals_deferred()``: each of the three only sets a flag; the master looks
at it after every step, stops, terminates and frees every instance, finalises the recording and
returns a result marked ``interrupted``; the CLI starts no further work, keeps what finished, and
exits with 128 + the signal's number (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP), the shell's
convention.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator

from orchestration.exit_codes import SIGNALLED

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Interrupted(Exception):
    """Raised by the CLI's own code (never inside an FMU call) to unwind once a signal was seen."""


class _State:
    requested = False
    signum: int | None = None  # the first of SIGNALS that arrived


STATE = _State()


def requested() -> bool:
    return STATE.requested


def signal_name() -> str:
    return signal.Signals(STATE.signum).name if STATE.signum else "SIGINT"


def exit_code() -> int:
    """128 + the number of the signal that stopped the command."""
    return SIGNALLED + (STATE.signum or signal.SIGINT)


def check() -> None:
    """Raise Interrupted if a signal was seen: call between units of work, never inside an FMU call."""
    if STATE.requested:
        raise Interrupted(f"interrupted by {signal_name()}")


class NothingRan(Interrupted):
    """A signal came while the command still imported and checked: nothing was built, run or written."""


def check_before_work() -> None:
    """Raise NothingRan if a signal was seen: call after a command's imports, before it builds or runs."""
    if STATE.requested:
        raise NothingRan("stopped before anything ran")


def _note(signum, frame) -> None:
    STATE.signum = STATE.signum or signum
    STATE.requested = True


@contextmanager
def signals_deferred() -> Iterator[None]:
    """While active (main thread only), SIGINT, SIGTERM and SIGHUP set ``STATE.requested``."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _note) for s in SIGNALS}
    STATE.requested, STATE.signum = False, None
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
