# cython: boundscheck=False, wraparound=False
"""The concurrent-learning (experience replay) stack of the SOTC tuning laws (30)/(31).

Reference: Dien, Luy, Lai & Hai (2023), J. Computer Science and Cybernetics, eqs. (30)/(31) and the
paragraph after them: P past samples are kept and their Bellman residuals are replayed in the weight
update, so that W keeps converging after the probing signal stops, provided
rank(eta(t_1), ..., eta(t_P)) = 10. The paper follows Chowdhary & Johnson's concurrent learning
(its reference [19]); keeping the samples that maximise the smallest singular value of the stack is
their data-selection rule (Chowdhary & Johnson, ACC 2011).

The CL sum of (30)/(31) is

    sum_i xi_i (eta_i^T W + r_i) = M W + b,   xi_i = eta_i / (eta_i^T eta_i + 1)^2,
    M = sum_i xi_i eta_i^T (symmetric >= 0),  b = sum_i xi_i r_i.

Two readings of what is replayed (``replay``):

* ``current`` (chosen): only z(t_i), g_v(t_i) = D^-1(phi(t_i)) and F_v(z(t_i)) are kept; eta_i and
  r_i are re-evaluated with the current W, i.e. with the policy (28) the critic now implies, by the
  controller's own formulas (``sotc_math``). The replayed residuals are the HJB residuals (29) at
  the stored points, and M, b change with W;
* ``stored`` (as printed): eta(t_i) and r(t_i) exactly as recorded (under the policy of time t_i).

Which samples are kept (``selection``):

* ``maxeig`` (chosen): fill the P rows, then swap a new sample in only for a gain well above what
  rounding can produce, the margin SWAP_MARGIN trace(M) = 1e3 eps trace(M). Rounding moves M's entries by
  a few eps trace(M) each, hence (Weyl's inequality) its eigenvalues by about n eps trace(M) (n = 10);
  the margin is a hundred times that. Eigenvalues below the margin do not count: the numerical rank
  counts the others, and a stack below full rank has lambda_min 0. A swap must raise one eigenvalue by
  more than the margin: at full rank lambda_min(M), and by more than 1 % too; below full rank the
  largest eigenvalue below the margin, which then clears it (the rank rises). A gain over the stack's
  own eigenvalue, not a level to reach: trial eigenvalues pile up just under a level, and an eigenvalue
  of M drifts across it with W (the ``current`` replay), so a level left decisions to rounding. Among
  swaps equal to within the margin, the oldest row goes. Eigenvalues are bisected to eps trace(M)
  (``fixed_linalg``), a thousandth of the margin; ``orchestration.study.swap_margin`` re-decides every
  offer with the thresholds moved by eps trace(M) and counts the decisions that change;
* ``fill`` keeps the first P records; ``fifo`` the newest P;
* ``maxeig-raw``: the earlier rule, the largest computed lambda_min of the P trial stacks and a 1 %
  gain, with no tolerance (it decides on rounding noise while the stack is rank-deficient).

Every sum runs in a fixed order over float64 buffers (``fixed_linalg``): the bits do not depend on the CPU.
"""
from __future__ import annotations

from array import array
from typing import Any, Sequence

from fmu_numerics.elementary import INTERPRETED, tanh
from fmu_numerics.fixed_linalg import (EPS, buffer, cholesky, dot, forward_substitute,
                                         smallest_eigenvalue, sturm_count, trace)
from fmu_controller.sotc_math import (N_BASIS, CriticConstants, critic_row, normalisation, policy_arguments,
                                      weights_buffer)

SELECTIONS = ("maxeig", "fill", "fifo", "maxeig-raw")
REPLAYS = ("current", "stored")
MAXEIG_GAIN = 1.01  # a swap must raise lambda_min(M) by more than 1 % ...
SWAP_MARGIN = 1e3 * EPS  # ... and by more than SWAP_MARGIN trace(M), a hundred times M's rounding level n eps trace(M)
_WIDTHS = {"eta": N_BASIS, "z": 4, "dinv": 3, "fe": 2}
if INTERPRETED:  # the Python build's numpy paths: the CL sums and the replay over all rows at once
    from fmu_controller.sotc_stack_interpreted import cl_matrix_numpy, replay_current_array


def cl_matrix(n: int, E: array, rew: array, M: array, b: array, sc: array) -> None:
    """M = sum_i sc_i eta_i eta_i^T and b = sum_i sc_i r_i eta_i over the first n rows of E (flat,
    n x 10), sc_i = 1 / (1 + |eta_i|^2)^2; rows in order, M's lower triangle mirrored. The interpreted
    core takes ``sotc_stack_interpreted.cl_matrix_numpy`` (the same bits; these loops in Python were half its controller's time)."""
    if INTERPRETED:
        cl_matrix_numpy(n, E, rew, M, b, sc)
        return
    N = N_BASIS
    for k in range(N * N):
        M[k] = 0.0
    for k in range(N):
        b[k] = 0.0
    for i in range(n):
        o = i * N
        ee = 0.0
        for k in range(N):
            ee += E[o + k] * E[o + k]
        sc[i] = 1.0 / normalisation(ee)
        for a in range(N):
            xa = E[o + a] * sc[i]
            b[a] += xa * rew[i]
            for c in range(a + 1):
                M[a * N + c] += xa * E[o + c]
    for a in range(N):
        for c in range(a):
            M[c * N + a] = M[a * N + c]


def cl_rate(M: array, b: array, W: array, out: array) -> None:
    """out = M W + b (rows of M in order)."""
    N = N_BASIS
    for a in range(N):
        acc = 0.0
        for c in range(N):
            acc += M[a * N + c] * W[c]
        out[a] = acc + b[a]


def replay_current(K: CriticConstants, n: int, W: array, z: array, dinv: array, fe: array, E: array,
                   rew: array) -> None:
    """eta_i and r_i of the first n rows re-evaluated at the weights W (the ``current`` replay): the
    policy (28) the critic W implies at z_i, and the controller's own ``critic_row``. The interpreted core
    takes ``sotc_stack_interpreted.replay_current_array`` (the same bits, all rows at once)."""
    if INTERPRETED:
        replay_current_array(K, n, W, z, dinv, fe, E, rew)
        return
    s = K.s
    for i in range(n):
        zp1, zp2, zv1, zv2 = z[4 * i], z[4 * i + 1], z[4 * i + 2], z[4 * i + 3]
        i11, i12, i22 = dinv[3 * i], dinv[3 * i + 1], dinv[3 * i + 2]
        x1, x2, x3, x4 = policy_arguments(K, zp1, zp2, zv1, zv2, W, i11, i12, i22)
        t1, t2, t3, t4 = tanh(x1), tanh(x2), tanh(x3), tanh(x4)
        rew[i] = critic_row(K, zp1, zp2, zv1, zv2, x1, x2, x3, x4, t1, t2, t3, t4, -s * t1, -s * t2, -s * t3,
                            -s * t4, fe[2 * i], fe[2 * i + 1], i11, i12, i22, E, i * N_BASIS)[4]


def rows_within(L: array, E: array, sc: array, P: int, y: array, inside: array) -> int:
    """inside[j] = 1 for each row j of E with sc_j |L^-1 eta_j|^2 < 1, else 0 (y is scratch); how many.
    These are the swaps that can pass ``CLStack._swap_full``'s threshold."""
    N = N_BASIS
    count = 0
    for j in range(P):
        forward_substitute(L, E, N, y, j * N)
        yy = 0.0
        for k in range(N):
            yy += y[k] * y[k]
        within = sc[j] * yy < 1.0
        inside[j] = 1.0 if within else 0.0
        count += within
    return count


def trial_matrix(M: array, sc_j: float, E: array, j: int, c_sc: float, eta: array, out: array) -> None:
    """out = M - sc_j eta_j eta_j^T + c_sc eta eta^T: the CL matrix with row j swapped for eta."""
    N = N_BASIS
    o = j * N
    for a in range(N):
        xa, ya = E[o + a] * sc_j, eta[a] * c_sc
        for c in range(a + 1):
            out[a * N + c] = M[a * N + c] - xa * E[o + c] + ya * eta[c]
            out[c * N + a] = out[a * N + c]


class CLStack:
    """P recorded samples and the CL sum M W + b of (30)/(31).

    ``constants`` are the controller's own (``sotc_math.CriticConstants``): the ``current`` replay
    re-evaluates eta_i and r_i with them. Compiled, ``sotc_stack.pxd`` makes this an extension type (C ints
    and doubles, every buffer also a C array: the recorded rows through ``_eta`` ... ``_t``), whose
    per-sample methods the kernel calls as C and which creates no Python object per sample; a Python
    subclass may still override ``_swap_row`` (``orchestration.study.swap_margin``)."""

    def __init__(self, P: int, selection: str, replay: str, constants: CriticConstants):
        self.P, self.selection, self.replay_form = P, selection, replay
        self._current, self._stored = replay == "current", replay == "stored"
        self._fill, self._fifo, self._raw = selection == "fill", selection == "fifo", selection == "maxeig-raw"
        self.constants = constants
        self.margin = SWAP_MARGIN  # relative to trace(M); a study may set another after construction
        N = N_BASIS
        self.M, self.b, self.sc = buffer(N * N), buffer(N), buffer(P)  # the CL sum at the last terms()
        self.E, self.rew_now = buffer(P * N), buffer(P)  # eta_i, r_i at the last terms()
        self._rate, self._c = buffer(N), buffer(N)
        self._d, self._e, self._v, self._p, self._y = buffer(N), buffer(N), buffer(N), buffer(N), buffer(N)
        self._work, self._A, self._L = buffer(N * N), buffer(N * N), buffer(N * N)
        self._inside, self._found, self._lams = buffer(P), buffer(P), buffer(P)
        self.clear()

    # --- contents --------------------------------------------------------------------------------

    def clear(self) -> None:
        P = self.P
        self.rows = {key: buffer(P * w) for key, w in _WIDTHS.items()}  # eta, z, dinv, fe as recorded
        self.rew = buffer(P)  # r(t_i) = z^T Theta z + Omega(mu_hat) as recorded
        self.t = buffer(P)  # record time t_i (the oldest row goes among equal swaps)
        self.count = 0  # filled rows
        self.next_row = 0  # row the FIFO overwrites next
        self.swaps = 0  # samples taken into the full stack
        self.min_eig = 0.0  # lambda_min(M) at the last offer (0 while numerically rank-deficient)
        self._bind()
        self.refresh()

    def _bind(self) -> None:
        """The recorded buffers under the names the per-sample methods use (C arrays when compiled)."""
        rows = self.rows
        self._eta, self._z, self._dinv, self._fe = rows["eta"], rows["z"], rows["dinv"], rows["fe"]
        self._rew, self._t = self.rew, self.t

    def to_state(self) -> dict[str, Any]:
        state: dict[str, Any] = {key: [list(a[i * _WIDTHS[key]:(i + 1) * _WIDTHS[key]]) for i in range(self.P)]
                                 for key, a in self.rows.items()}
        state.update(rew=list(self.rew), t=list(self.t), count=self.count, next_row=self.next_row,
                     swaps=self.swaps, min_eig=self.min_eig)
        return state

    def from_state(self, state: dict[str, Any]) -> None:
        rows = {}
        for key, w in _WIDTHS.items():
            flat = [float(v) for row in state[key] for v in row]
            if len(state[key]) != self.P or len(flat) != self.P * w:
                raise ValueError(f"CL stack state '{key}' must be {self.P} rows of {w} (P = {self.P})")
            rows[key] = buffer(0)
            rows[key].fromlist(flat)
        rew, t = buffer(0), buffer(0)
        rew.fromlist([float(v) for v in state["rew"]])
        t.fromlist([float(v) for v in state["t"]])
        if len(rew) != self.P or len(t) != self.P:
            raise ValueError(f"CL stack state 'rew' and 't' must have {self.P} entries (P = {self.P})")
        count, next_row, swaps = int(state["count"]), int(state["next_row"]), int(state["swaps"])
        if not (0 <= count <= self.P and 0 <= next_row < self.P and swaps >= 0):
            raise ValueError(f"CL stack state: count {count} / next_row {next_row} / swaps {swaps} out of range "
                             f"for P = {self.P}")
        self.rows, self.rew, self.t = rows, rew, t
        self.count, self.next_row, self.swaps, self.min_eig = count, next_row, swaps, float(state["min_eig"])
        self._bind()
        self.refresh()

    # --- the CL sum ----------------------------------------------------------------------------------

    def refresh(self) -> None:
        """Rebuild what the ``stored`` replay derives from the rows (M, b do not depend on W there)."""
        if self._stored:
            self.E[:] = self._eta
            self.rew_now[:] = self._rew
            cl_matrix(self.count, self.E, self.rew_now, self.M, self.b, self.sc)

    def terms(self, W: Sequence[float]) -> array:
        """``cl_terms`` at weights W given as any sequence of 10 floats (``weights_buffer``)."""
        return self.cl_terms(weights_buffer(W))

    def cl_terms(self, W: array) -> array:
        """The CL sum M W + b of (30)/(31) at the weights W (a float64 buffer; the result is a buffer kept by
        the stack, overwritten by the next call); M, b stay as ``self.M``, ``self.b``, with the rows
        ``self.E`` and their scales ``self.sc``."""
        if self._current:
            replay_current(self.constants, self.count, W, self._z, self._dinv, self._fe, self.E, self.rew_now)
            cl_matrix(self.count, self.E, self.rew_now, self.M, self.b, self.sc)
        cl_rate(self.M, self.b, W, self._rate)
        return self._rate

    def spectrum(self, shift: float = 0.0) -> tuple[float, int, float]:
        """(lambda_min, numerical rank, margin) of the CL matrix of the last ``terms``: margin =
        ``margin`` trace(M), the rank counts the eigenvalues at or above margin + shift, and lambda_min is
        0 below full rank. ``shift`` is 0 but where a study re-decides with moved thresholds (``_swap_row``)."""
        n = N_BASIS
        margin = self.margin * trace(self.M, n)
        lam = self._smallest(self.M, 1)
        rank = n - sturm_count(self._d, self._e, n, margin + shift) if margin > 0.0 else 0
        return (lam if rank == n else 0.0), rank, margin

    def min_eig_at(self, W: list) -> float:
        """lambda_min of the CL matrix at the weights W (0 when empty or rank-deficient)."""
        if not self.count:
            return 0.0
        self.terms(W)
        return self.spectrum()[0]

    # --- recording -------------------------------------------------------------------------------

    def record(self, eta: array, rew: float, z: array, dinv: array, fe: array, t: float, terms_ready: bool) -> bool:
        """Offer the sample of time t (eta, z, dinv, fe: float64 buffers); ``terms_ready``: ``terms`` ran at the
        weights the sample was evaluated with (``maxeig`` swaps only then). Returns whether the stack changed."""
        ready = terms_ready and self.count > 0
        lam, rank, margin = 0.0, 0, 0.0
        if ready:
            lam, rank, margin = self.spectrum()
            self.min_eig = lam
        if self.count < self.P:
            row = self.count
            self.count += 1
        elif self._fill:
            return False
        elif self._fifo:
            row = self.next_row
            self.next_row = (self.next_row + 1) % self.P
            self.swaps += 1
        else:
            row = self._swap_row(eta, (lam, rank, margin), 0.0) if ready else -1
            if row < 0:
                return False
            self.swaps += 1
        self._put(row, eta, rew, z, dinv, fe, t)
        return True

    def _smallest(self, M: array, k: int = 1) -> float:
        return smallest_eigenvalue(M, N_BASIS, self._d, self._e, self._A, self._v, self._p, k)

    def _put(self, row: int, eta: array, rew: float, z: array, dinv: array, fe: array, t: float) -> None:
        N = N_BASIS
        for k in range(N):
            self._eta[row * N + k] = eta[k]
        for k in range(4):
            self._z[row * 4 + k] = z[k]
        for k in range(3):
            self._dinv[row * 3 + k] = dinv[k]
        for k in range(2):
            self._fe[row * 2 + k] = fe[k]
        self._rew[row], self._t[row] = rew, t
        self.refresh()

    def _swap_row(self, eta: array, spectrum: tuple[float, int, float], shift: float = 0.0) -> int:
        """The row a new sample eta replaces under ``maxeig``/``maxeig-raw``, or -1 (no swap); ``spectrum``
        as ``spectrum(shift)`` gives it. A swap must raise lambda_k, the k-th smallest eigenvalue of M
        (k = 1 at full rank, else the largest of the n - rank below the margin), from max(lambda_k, 0) by
        more than the least gain max(1 % of that, the margin); ``shift`` moves the gain, the rank's
        threshold and the tie window alike (0 but in a study of the decisions). By Weyl's inequality a swap
        raises lambda_k by at most |eta|^2 / (1 + |eta|^2)^2, so a sample not above the least gain is
        refused at once."""
        N, c = N_BASIS, self._c
        for a in range(N):
            c[a] = eta[a]
        ee = dot(c, c, N)
        c_sc = 1.0 / normalisation(ee)
        lam, rank, margin = spectrum
        if self._raw:
            lam = self._smallest(self.M, 1)
            return -1 if ee * c_sc <= (MAXEIG_GAIN - 1.0) * lam else self._swap_raw(c_sc, lam)
        k = max(1, N - rank)
        low = lam if rank == N else max(self._smallest(self.M, k), 0.0)
        gain = max((MAXEIG_GAIN - 1.0) * low, margin) + shift
        if ee * c_sc <= gain:
            return -1
        return self._swap_raising(c_sc, k, low + gain, margin + shift)

    def _swap_raising(self, c_sc: float, k: int, thr: float, window: float) -> int:
        """Of the trials whose k-th smallest eigenvalue exceeds thr (marked in ``_found``, the eigenvalues in
        ``_lams``), the largest to within ``window``, then the oldest row. For k = 1 a necessary test first
        (``_may_pass``); the computed eigenvalue decides."""
        B, found, lams = self._work, self._found, self._lams
        if k == 1 and not self._may_pass(c_sc, thr):
            return -1
        for j in range(self.P):
            found[j] = 0.0
            if k > 1 or self._inside[j]:
                trial_matrix(self.M, self.sc[j], self.E, j, c_sc, self._c, B)
                lams[j] = self._smallest(B, k)
                if lams[j] > thr:
                    found[j] = 1.0
        return self._oldest_best(window)

    def _may_pass(self, c_sc: float, thr: float) -> bool:
        """Whether any trial can have lambda_min > thr: B = M + c c^T - thr I must be positive definite,
        and then trial j can only if sc_j |L^-1 eta_j|^2 < 1 (B = L L^T; marks them in ``_inside``)."""
        N, B, L = N_BASIS, self._work, self._L
        trial_matrix(self.M, 0.0, self.E, 0, c_sc, self._c, B)  # M + c c^T (row 0 taken with weight 0)
        for a in range(N):
            B[a * N + a] -= thr
        return cholesky(B, N, L) and rows_within(L, self.E, self.sc, self.P, self._y, self._inside) > 0

    def _oldest_best(self, window: float) -> int:
        """Of the rows marked in ``_found`` (eigenvalues in ``_lams``), the largest eigenvalue to within
        ``window``, then the oldest row (then the lowest index); -1 if there is none."""
        found, lams, t = self._found, self._lams, self._t
        row, best = -1, 0.0
        for j in range(self.P):
            if found[j] and (row < 0 or lams[j] > best):
                row, best = j, lams[j]
        if row < 0:
            return -1
        row = -1
        for j in range(self.P):
            if found[j] and lams[j] >= best - window and (row < 0 or t[j] < t[row]):
                row = j
        return row

    def _swap_raw(self, c_sc: float, lam: float) -> int:
        B, row, best = self._work, -1, 0.0
        for j in range(self.P):
            trial_matrix(self.M, self.sc[j], self.E, j, c_sc, self._c, B)
            trial = self._smallest(B, 1)
            if row < 0 or trial > best:
                row, best = j, trial
        return row if best > MAXEIG_GAIN * lam else -1
