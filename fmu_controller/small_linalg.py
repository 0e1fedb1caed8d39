"""numpy's LAPACK kernels for the 10 x 10 problems of the SOTC critic, without the per-call checks.

``numpy.linalg.eigvalsh`` and ``numpy.linalg.solve`` spend more time on argument checks and error
state set-up than on a 10 x 10 problem (about 7 us against 4 us per call, measured); the
controller makes two such calls per sample (and a batch of P eigenvalue problems when it
considers a swap in the CL stack). These call the same compiled kernels
(``numpy.linalg._umath_linalg``), so the results are identical bit for bit; on a numpy without
that module they fall back to the public functions. Inputs must be finite float64 arrays (the
callers check their outputs for finiteness)."""
from __future__ import annotations

import numpy as np

try:
    from numpy.linalg import _umath_linalg as _kernels

    def smallest_eigenvalue(M: np.ndarray) -> float:
        """lambda_min of the symmetric M (lower triangle used, as ``numpy.linalg.eigvalsh``)."""
        return float(_kernels.eigvalsh_lo(M, signature="d->d")[0])

    def smallest_eigenvalues(Ms: np.ndarray) -> np.ndarray:
        """lambda_min of each symmetric matrix of the stack Ms (k, n, n)."""
        return _kernels.eigvalsh_lo(Ms, signature="d->d")[:, 0]

    def solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
        """x with A x = b (LU with partial pivoting, as ``numpy.linalg.solve``); a singular A raises
        ``LinAlgError`` as numpy's does (the kernel returns NaN, then the public function is asked)."""
        x = _kernels.solve1(A, b, signature="dd->d")
        if not np.isfinite(x).all():
            with np.errstate(invalid="ignore"):
                return np.linalg.solve(A, b)
        return x
except (ImportError, AttributeError):  # pragma: no cover - other numpy layouts
    def smallest_eigenvalue(M: np.ndarray) -> float:
        return float(np.linalg.eigvalsh(M)[0])

    def smallest_eigenvalues(Ms: np.ndarray) -> np.ndarray:
        return np.linalg.eigvalsh(Ms)[:, 0]

    def solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.linalg.solve(A, b)
