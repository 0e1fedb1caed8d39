"""numpy's BLAS threads for the ``sotc-cosim`` process: one, unless the user chose a number.

No command gains from BLAS threads: the cores' linear algebra is the project's own fixed-order loops,
the rest are products of a few columns (the critic's 10 x 10, the studies' n x 4), while OpenBLAS's pool
costs its start at numpy's import and spins idle on the core that the recording's writer process (and a
sweep's second worker, which inherits the setting) works on. OpenBLAS reads its variables once, when
numpy loads it: ``one_blas_thread`` must run before anything imports numpy."""
from __future__ import annotations

import os

BLAS_THREADS = "OPENBLAS_NUM_THREADS"
USER_CHOICES = (BLAS_THREADS, "GOTO_NUM_THREADS", "OMP_NUM_THREADS")  # what OpenBLAS reads, in its order
_set_here = False  # whether this process chose the BLAS threads (not the user)


def one_blas_thread() -> None:
    """One BLAS thread for this process and its children, unless the user set any of ``USER_CHOICES``."""
    global _set_here
    if not any(name in os.environ for name in USER_CHOICES):
        os.environ[BLAS_THREADS] = "1"
        _set_here = True


def user_environment() -> dict[str, str]:
    """This process's environment without what ``one_blas_thread`` set: for the processes the bench times
    as a user starts them (a plain numpy script gets OpenBLAS's own default there)."""
    env = dict(os.environ)
    if _set_here:
        env.pop(BLAS_THREADS, None)
    return env
