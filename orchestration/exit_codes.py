"""What every sotc-cosim command exits with, and the error it reports in one line instead of a
traceback."""
from __future__ import annotations

OK = 0
FAILED = 1  # the command ran; a run, a point or a check failed, and it says which
USAGE = 2  # the request cannot be run as given (argument, scenario, path): one line, nothing written
SIGNALLED = 128  # + the signal's number (130 SIGINT, 143 SIGTERM, 129 SIGHUP): stopped between two steps,
# finished results kept (orchestration.run.interrupt)
PIPE_CLOSED = 141  # 128 + SIGPIPE: the reader of the output went away (`| head`), as a shell tool reports it


class UsageError(ValueError):
    """A request that cannot be run as given; the message names the argument, key or path and what is
    allowed. The CLI prints it on one line and exits with ``USAGE``."""
