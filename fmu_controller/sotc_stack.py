"""The concurrent-learning (experience replay) stack of the SOTC tuning laws (30)/(31).

Reference: Dien, Luy, Lai & Hai (2023), J. Computer Science and Cybernetics, eqs. (30)/(31) and the
paragraph after them: P past samples are kept and their Bellman residuals are replayed in the weight
update, so that W keeps converging after the probing signal stops, provided
rank(eta(t_1), ..., eta(t_P)) = 10.

The CL sum of (30)/(31) is

    sum_i xi_i (eta_i^T W + r_i) = M W + b,   xi_i = eta_i / (eta_i^T eta_i + 1)^2,
    M = sum_i xi_i eta_i^T (symmetric >= 0),  b = sum_i xi_i r_i.

Two readings of what is replayed (``replay``):

* ``current`` (chosen): only z(t_i), g_v(t_i) = D^-1(phi(t_i)) and F_v(z(t_i)) are kept; eta_i and
  r_i = z_i^T Theta z_i + Omega(mu_hat_i) are re-evaluated with the current W, i.e. with the policy
  (28) the critic now implies. The replayed residuals are then the HJB residuals (29) at the stored
  points, and M, b change with W;
* ``stored`` (as printed): eta(t_i) and r(t_i) exactly as recorded (under the policy of time t_i).

Which samples are kept (``selection``): ``maxeig`` (chosen) fills the P rows, then swaps a new
sample in only if that raises lambda_min(M) by more than 1 % (singular-value-maximising selection);
``fill`` keeps the first P records; ``fifo`` the newest P.

Arrays are preallocated (P x ...) and every derived quantity is rebuilt from them in the same order
of operations, so a restored state reproduces the same floating-point results.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from fmu_controller.small_linalg import smallest_eigenvalue, smallest_eigenvalues
from fmu_controller.sotc_math import N_BASIS, basis_jacobian, omega_of_arg_rows

SELECTIONS = ("maxeig", "fill", "fifo")
REPLAYS = ("current", "stored")
MAXEIG_GAIN = 1.01  # a swap must raise lambda_min(M) by more than 1 %


class CLStack:
    """P recorded samples and the CL sum M W + b of (30)/(31).

    ``s, r, theta, lam1, lam2, backstepping`` are the controller constants the ``current`` replay
    needs to re-evaluate eta_i and r_i (saturation level, R, Theta, Lambda_1, Lambda_2, reading of
    chi_vd^a)."""

    def __init__(self, P: int, selection: str, replay: str, s: float, r: Sequence[float],
                 theta: Sequence[float], lam1: Sequence[float], lam2: Sequence[float], backstepping: bool,
                 coupled: bool = True):
        self.P, self.selection, self.replay_form = P, selection, replay
        self.s = s
        self.r = np.array(r, dtype=float)
        self.theta = np.array(theta, dtype=float)
        self.lam1, self.lam2, self.backstepping = tuple(lam1), tuple(lam2), backstepping
        self.coupled = coupled  # eta_i with the coupling terms +z_v, -z_phi of (6) (else (7) as printed)
        self.clear()

    # --- contents --------------------------------------------------------------------------------

    def clear(self) -> None:
        P = self.P
        self.eta = np.zeros((P, N_BASIS))  # eta(t_i) as recorded
        self.rew = np.zeros(P)  # r(t_i) = z^T Theta z + Omega(mu_hat) as recorded
        self.z = np.zeros((P, 4))  # z(t_i)
        self.dinv = np.zeros((P, 3))  # (D^-1_11, D^-1_12, D^-1_22) at t_i
        self.fe = np.zeros((P, 2))  # F_v(z_phi, z_v) at t_i
        self.count = 0  # filled rows
        self.next_row = 0  # row the FIFO overwrites next
        self.refresh()

    def to_state(self) -> dict[str, Any]:
        return {
            "eta": self.eta.tolist(), "rew": self.rew.tolist(), "z": self.z.tolist(),
            "dinv": self.dinv.tolist(), "fe": self.fe.tolist(),
            "count": self.count, "next_row": self.next_row,
        }

    def from_state(self, state: dict[str, Any]) -> None:
        shapes = {"eta": (self.P, N_BASIS), "rew": (self.P,), "z": (self.P, 4), "dinv": (self.P, 3), "fe": (self.P, 2)}
        arrays = {}
        for key, shape in shapes.items():
            a = np.array(state[key], dtype=float)
            if a.shape != shape:
                raise ValueError(
                    f"CL stack state '{key}' has shape {a.shape}, this controller needs {shape} (P = {self.P})")
            arrays[key] = a
        count, next_row = int(state["count"]), int(state["next_row"])
        if not (0 <= count <= self.P and 0 <= next_row < self.P):
            raise ValueError(f"CL stack state: count {count} / next_row {next_row} out of range for P = {self.P}")
        self.eta, self.rew, self.z, self.dinv, self.fe = (arrays[k] for k in shapes)
        self.count, self.next_row = count, next_row
        self.refresh()

    # --- derived quantities ----------------------------------------------------------------------

    def refresh(self) -> None:
        """Rebuild everything derived from the rows: the recorded M, b, lambda_min(M), and the
        per-row tensors that make ``replay`` a handful of array operations (the arguments of (28)
        are linear in W, eta_i is affine in mu_hat_i)."""
        E = self.eta
        scale = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
        Xi = E * scale[:, None]
        self.M_rec = Xi.T @ E
        self.b_rec = Xi.T @ self.rew
        self.min_eig_rec = smallest_eigenvalue(self.M_rec) if self.count else 0.0
        n = self.count
        Z, Di, Fe = self.z[:n], self.dinv[:n], self.fe[:n]
        s, r = self.s, self.r
        jac = np.array([basis_jacobian(z) for z in Z]).reshape(n, N_BASIS, 4)  # d zeta / dz at z_i
        # eq. (28): x_i = K_i grad(zeta(z_i))^T W, K_i = diag(1/(2 s r1), 1/(2 s r2), R_v^-1 D_i^-1 / (2 s))
        K = np.zeros((n, 4, 4))
        K[:, 0, 0] = 1.0 / (2.0 * s * r[0])
        K[:, 1, 1] = 1.0 / (2.0 * s * r[1])
        K[:, 2, 2], K[:, 2, 3] = Di[:, 0] / (2.0 * s * r[2]), Di[:, 1] / (2.0 * s * r[2])
        K[:, 3, 2], K[:, 3, 3] = Di[:, 1] / (2.0 * s * r[3]), Di[:, 2] / (2.0 * s * r[3])
        self._AX = np.einsum("nij,nkj->nik", K, jac)  # (n, 4, 10)
        # eqs. (6)/(7): zdot_i = F_bar(z_i) (with the coupling terms of (6)) + g_i mu_hat_i
        F = np.empty((n, 4))
        if self.backstepping:
            F[:, 0] = -self.lam1[0] * Z[:, 0] + Z[:, 2]
            F[:, 1] = -self.lam1[1] * Z[:, 1] + Z[:, 3]
        else:
            F[:, 0] = (1.0 + self.lam1[0]) * Z[:, 2]
            F[:, 1] = (1.0 + self.lam1[1]) * Z[:, 3]
        F[:, 2] = Fe[:, 0] - self.lam2[0] * Z[:, 2] - Z[:, 0]
        F[:, 3] = Fe[:, 1] - self.lam2[1] * Z[:, 3] - Z[:, 1]
        if not self.coupled:
            F[:, :2] -= Z[:, 2:]
            F[:, 2:] += Z[:, :2]
        g = np.zeros((n, 4, 4))
        g[:, 0, 0] = g[:, 1, 1] = 1.0
        g[:, 2, 2], g[:, 2, 3], g[:, 3, 2], g[:, 3, 3] = Di[:, 0], Di[:, 1], Di[:, 1], Di[:, 2]
        self._eta0 = np.einsum("nkj,nj->nk", jac, F)  # eta_i at mu = 0
        self._JG = np.einsum("nkj,nji->nki", jac, g)  # eta_i = eta0_i + JG_i mu_i
        self._q = (Z * Z) @ self.theta  # z_i^T Theta z_i

    def terms(self, W: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(M, b, eta rows, lambda_min(M)) for weights W: the CL sum of (30)/(31) is M W + b."""
        if self.replay_form == "stored":
            return self.M_rec, self.b_rec, self.eta, self.min_eig_rec
        X = self._AX @ W  # (n, 4): arguments of (28) at the stored z_i
        E = self._eta0 + np.einsum("nki,ni->nk", self._JG, np.tanh(X) * -self.s)
        rew = self._q + omega_of_arg_rows(X, self.s, self.r)  # r_i with Omega of eq. (17)
        scale = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
        Xi = E * scale[:, None]
        M = Xi.T @ E
        return M, Xi.T @ rew, E, smallest_eigenvalue(M)

    # --- recording -------------------------------------------------------------------------------

    def record(self, eta: np.ndarray, rew: float, z: Sequence[float], dinv: Sequence[float], fe: Sequence[float],
               M: np.ndarray | None, E: np.ndarray | None, min_eig: float) -> bool:
        """Offer one sample; ``M, E, min_eig`` are the CL terms at the weights the sample was
        evaluated with (used by ``maxeig``). Returns whether the stack changed."""
        if self.count < self.P:
            row = self.count
            self.count += 1
        elif self.selection == "fill":
            return False
        elif self.selection == "fifo":
            row = self.next_row
            self.next_row = (self.next_row + 1) % self.P
        else:
            # maxeig: by Weyl's inequality a swap raises lambda_min(M) by at most
            # lambda_max(xi eta^T) = |eta|^2 / (1 + |eta|^2)^2, so small samples are skipped at once
            etaeta = float(eta @ eta)
            cand_eig = etaeta / (1.0 + etaeta) ** 2
            if cand_eig <= (MAXEIG_GAIN - 1.0) * min_eig or M is None or E is None:
                return False
            sc = 1.0 / (1.0 + np.einsum("ij,ij->i", E, E)) ** 2
            cand = np.outer(eta, eta) * (1.0 / (1.0 + etaeta) ** 2)
            trial = M[None, :, :] - np.einsum("i,ij,ik->ijk", sc, E, E) + cand[None, :, :]
            eigs = smallest_eigenvalues(trial)
            row = int(np.argmax(eigs))
            if not eigs[row] > MAXEIG_GAIN * min_eig:
                return False
        self.eta[row] = eta
        self.rew[row] = rew
        self.z[row] = z
        self.dinv[row] = dinv
        self.fe[row] = fe
        self.refresh()
        return True
