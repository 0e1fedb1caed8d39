"""The continuous-time algebraic Riccati equation, numpy only (no scipy inside the FMUs).

    A'P + PA - P B R^-1 B' P + Q = 0,   P = P' >= 0 stabilising                       (CARE)

Solved from the stable invariant subspace of the Hamiltonian matrix

    Z = [[A, -B R^-1 B'], [-Q, -A']],   Z [U1; U2] = [U1; U2] L,  Re(L) < 0,  P = U2 U1^-1

and then polished by Newton-Kleinman steps (Kleinman 1968): with K = R^-1 B'P and A_K = A - BK,
solve the Lyapunov equation A_K'P+ + P+ A_K = -(Q + K'RK) for P+. The controllers here solve 4x4
problems once at construction, so the Lyapunov equation is solved through its Kronecker form.
``tests/test_baselines.py`` checks the result against scipy's Schur-based solver.
"""
from __future__ import annotations

import numpy as np

NEWTON_STEPS = 3


class RiccatiError(ValueError):
    pass


def _lyapunov(a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """X with A'X + XA = -C (small systems: Kronecker form)."""
    n = a.shape[0]
    eye = np.eye(n)
    x = np.linalg.solve(np.kron(eye, a.T) + np.kron(a.T, eye), -c.reshape(-1))
    x = x.reshape(n, n)
    return (x + x.T) / 2


def solve_care(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The stabilising solution P of (CARE); RiccatiError if the problem has none."""
    n = a.shape[0]
    r_inv_bt = np.linalg.solve(r, b.T)
    z = np.block([[a, -b @ r_inv_bt], [-q, -a.T]])
    values, vectors = np.linalg.eig(z)
    stable = values.real < 0
    if stable.sum() != n:
        raise RiccatiError("the Hamiltonian has eigenvalues on the imaginary axis: no stabilising solution")
    u1, u2 = vectors[:n, stable], vectors[n:, stable]
    try:
        p = np.real(np.linalg.solve(u1.T, u2.T).T)
    except np.linalg.LinAlgError as exc:
        raise RiccatiError(f"no stabilising solution: {exc}") from exc
    p = (p + p.T) / 2
    for _ in range(NEWTON_STEPS):
        k = r_inv_bt @ p
        p = _lyapunov(a - b @ k, q + k.T @ r @ k)
    if not np.all(np.isfinite(p)):
        raise RiccatiError("the Riccati solution is not finite")
    return p
