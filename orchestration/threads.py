"""numpy's BLAS threads for the ``sotc-cosim`` process: one, unless the user set ``OPENBLAS_NUM_THREADS``.

No command multiplies a matrix larger than the critic's 10 x 10, where OpenBLAS runs one thread anyway,
while its pool costs its start at numpy's import and spins idle on the core that the recording's writer
process (and a sweep's second worker, which inherits the setting) works on. OpenBLAS reads the variable
once, when numpy loads it: ``one_blas_thread`` must run before anything imports numpy."""
from __future__ import annotations

import os

BLAS_THREADS = "OPENBLAS_NUM_THREADS"
_set_here = False  # whether this process chose the BLAS threads (not the user)


def one_blas_thread() -> None:
    """One BLAS thread for this process and its children, unless the user chose a number."""
    global _set_here
    if BLAS_THREADS not in os.environ:
        os.environ[BLAS_THREADS] = "1"
        _set_here = True


def user_environment() -> dict[str, str]:
    """This process's environment without what ``one_blas_thread`` set: for the processes the bench times
    as a user starts them (a plain numpy script gets OpenBLAS's own default there)."""
    env = dict(os.environ)
    if _set_here:
        env.pop(BLAS_THREADS, None)
    return env
