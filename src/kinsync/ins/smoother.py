"""Rauch–Tung–Striebel smoothing of the closed-loop error-state INS/GNSS filter.

**What is smoothed.** The forward filter (`kinsync.ins.filter`) feeds every update back
into the mechanisation, so its error-state estimate is zero after each epoch: the
forward solution is the *nominal* state ``n_k`` with covariance ``P_k``. The smoother
estimates, for every IMU epoch, the error ``x_k^s`` of that nominal state given all the
data (``true ≈ n_k ⊖ x_k^s``, the same feedback operation as the filter), with
covariance ``P_k^s``, and applies it to the forward nominal states.

**Recursion.** The fixed-interval RTS smoother
``x_k^s = x_k^+ + A_k (x_{k+1}^s - x_{k+1}^-)``, ``A_k = P_k^+ Φ_{k+1}^T (P_{k+1}^-)^{-1}``
(Rauch, Tung & Striebel 1965) is run in its equivalent adjoint ("modified
Bryson–Frazier", Bierman 1973) form, which needs no inverse of the n×n predicted
covariance (ill-conditioned: bias variances ~1e-10 beside position variances ~1)::

    λ_N = 0, Λ_N = 0                                   (after the last epoch)
    at an update (z = H x + v, ν = z - H x^-, S = H P^- H^T + R,
                  K = P^- H^T S^{-1}, C = I - K H):
        λ_k^- = -H^T S^{-1} ν + C^T λ_k^+
        Λ_k^- =  H^T S^{-1} H + C^T Λ_k^+ C
    between epochs:  λ_{k-1}^+ = Φ_k^T λ_k^-,   Λ_{k-1}^+ = Φ_k^T Λ_k^- Φ_k
    x_k^s = x_k^+ - P_k^+ λ_k^+,   P_k^s = P_k^+ - P_k^+ Λ_k^+ P_k^+

**Closed-loop resets.** The forward estimates ``x_k^-`` (relative to the predicted
nominal) and ``x_k^+`` (relative to the corrected nominal) are both zero, and the
update's correction ``Δ_k = K ν`` went into the nominal state. The adjoint ``λ`` is
the scaled difference ``P^{-1}(x^+ - x^s)`` of two estimates expressed in the same
reference, so it does not change when the reference moves with the reset, and
``ν = z`` (the stored INS-minus-GNSS value). Hence ``x_k^s = -P_k^+ λ_k^+`` relative
to the forward output ``n_k``. This is the same as the textbook RTS form with resets,
``x_k^s = A_k (x_{k+1}^s + Δ_{k+1})``, without storing ``Δ``.

**Memory.** ``Φ`` and ``P`` are not stored per epoch (87 000 epochs × 3 × 21×21
doubles would be 920 MB). The forward pass stores, at each GNSS update, ``P^-``,
``P^+``, the accepted rows of ``H``, their variances and ``z``, plus a plain
checkpoint every `kinsync.ins.forward_run.CHECKPOINT_EVERY` epochs (about 10 MB for the
NaveGo set). Between two checkpoints no update happens, so ``P_k`` is recomputed by
propagating ``P^+`` of the earlier checkpoint with ``Φ_k`` and ``Q_k`` rebuilt from
the stored nominal states (the very same compiled code and inputs as in the forward
pass, hence the same numbers), kept for that segment only, and the backward
recursion runs through the segment. The cost is a second covariance propagation.
The smoothed error and its covariance entries of a segment are applied to the nominal
states and turned into σ as soon as the segment is done (`smooth_checkpoints` hands
them over one segment at a time), so nothing of the smoother but the checkpoints
grows with the record: per IMU epoch the run holds the forward states and σ (52
floats), which `run_ins` overwrites with the smoothed ones, and the checkpoints (about
28 floats at 200 Hz IMU and 5 Hz GNSS). It held 138 floats more before (the smoothed
error, its covariance entries and separate outputs): 14 GB for 10 h at 200 Hz.

**Output.** Per epoch, the smoothed error's variances and the covariance entries the
solution's standard deviations need (`smoothed_solution_std`): the attitude-velocity
block, for the NED velocity error ``δv = δv' + [v×] φ`` of the modified φ-angle model,
and each axis' turn-on-bias/instability covariance, for the total bias.

References
----------
H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear dynamic
systems", AIAA Journal 3(8), 1445-1450, 1965.
G. J. Bierman, "Fixed interval smoothing with discrete measurements", International
Journal of Control 18(1), 65-75, 1973.
E.-H. Shin, *Estimation Techniques for Low-Cost Inertial Navigation*, PhD thesis,
University of Calgary, UCGE Report 20219, 2005 (RTS smoothing of closed-loop INS
error states).
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, ch. 3 (Kalman smoothing).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple, cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray
from kinsync.ins._ekf import (
    N_NAV,
    N_OUT,
    X_BA,
    X_BG,
    X_MA,
    X_MG,
    feedback,
    propagate_cov,
    solution_std,
    step_matrices,
    support_index,
    support_transition,
)
from kinsync.ins.forward_run import Checkpoints, ForwardRun
from kinsync.ins.measurements import ImuData
from kinsync.ins.strapdown import I_CVAR
from kinsync.progress import Progress, report

__all__ = [
    "SegmentDone",
    "SegmentMatrices",
    "SmoothedCovariance",
    "smooth_checkpoints",
    "smooth_forward_run",
    "smoothed_solution_std",
]

_jit = cached_njit()

SegmentMatrices = Callable[[int, int, bool, FloatArray, FloatArray, FloatArray], None]
"""``fill(e, L, has_next, Phi_buf, q_buf, q_nav_buf)``: ``Φ_{e+i}``, the diagonal of
``Q_{e+i}`` and its 6×6 attitude-velocity block into ``Phi_buf[i]``, ``q_buf[i]``,
``q_nav_buf[i]`` for ``i = 1 .. L-1`` (and ``i = L`` when ``has_next``)."""


class SmoothedCovariance(NamedTuple):
    """The smoothed covariance entries kept per epoch, indexed by absolute IMU epoch.

    Attributes
    ----------
    var : ndarray, shape (n_epochs, n)
        Variances of the error states.
    nav : ndarray, shape (n_epochs, 6, 6)
        The attitude-velocity block.
    bias_cross : ndarray, shape (n_epochs, 6)
        Covariance of each axis' turn-on bias and instability, gyro then accelerometer.
    """

    var: FloatArray
    nav: FloatArray
    bias_cross: FloatArray


SegmentDone = Callable[[int, FloatArray, SmoothedCovariance], None]
"""``done(e, dx, cov)``: the smoothed error ``dx`` (L, n) and its covariance entries
``cov`` (L rows) at epochs ``e .. e+L-1``; the buffers are reused for the next segment."""


def new_smoothed_covariance(n_epochs: int, n_err: int) -> SmoothedCovariance:
    """Zeroed `SmoothedCovariance` for ``n_epochs`` epochs of ``n_err`` error states."""
    return SmoothedCovariance(
        var=np.zeros((n_epochs, n_err)),
        nav=np.zeros((n_epochs, 6, 6)),
        bias_cross=np.zeros((n_epochs, 6)),
    )


def _propagate_info(Lam: FloatArray, Phi: FloatArray, U: FloatArray) -> None:  # pragma: no cover
    """``Λ ← Φ^T Λ Φ`` in place for a block-structured ``Φ`` (see `kinsync.ins._ekf`)."""
    n = Lam.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for m in range(N_NAV):
                acc += Lam[i, m] * Phi[m, j]
            if j >= N_NAV:
                acc += Lam[i, j] * Phi[j, j]
            U[i, j] = acc
    for i in range(n):
        for j in range(i, n):
            acc = 0.0
            for m in range(N_NAV):
                acc += Phi[m, i] * U[m, j]
            if i >= N_NAV:
                acc += Phi[i, i] * U[i, j]
            Lam[i, j] = acc
            Lam[j, i] = acc


propagate_info = _jit(_propagate_info)


def _smooth_segment(  # noqa: PLR0912 - one flat loop is what numba compiles best
    P_start: FloatArray,
    Phi_buf: FloatArray,
    q_buf: FloatArray,
    q_nav_buf: FloatArray,
    L: int,
    has_next: bool,
    lam: FloatArray,
    Lam: FloatArray,
    out_dx: FloatArray,
    out: SmoothedCovariance,
    P_buf: FloatArray,
) -> None:  # pragma: no cover - compiled by numba; tested against batch least squares
    """Backward recursion through one segment of ``L`` epochs without updates.

    On entry ``lam``/``Lam`` hold ``λ^-``/``Λ^-`` at the next checkpoint's epoch (or
    zero after the last epoch when ``has_next`` is False); on exit ``λ^+``/``Λ^+`` at the
    first epoch of the segment. ``out_dx[i]`` and the rows ``i`` of ``out`` receive the
    smoothed error and its covariance entries at epoch ``i`` of the segment.
    """
    n = P_start.shape[0]
    T = np.empty((N_NAV, n))
    U = np.empty((n, n))
    M = np.empty((n, n))
    tmp = np.empty(n)
    if L == 0:
        return
    # Element loops, not slice assignment: numba's broadcasting assignment compiles
    # its shape-error path (string formatting), seconds on a first run.
    for a in range(n):
        for b in range(n):
            P_buf[0, a, b] = P_start[a, b]
    for i in range(1, L):
        for a in range(n):
            for b in range(n):
                P_buf[i, a, b] = P_buf[i - 1, a, b]
        propagate_cov(P_buf[i], Phi_buf[i], q_buf[i], q_nav_buf[i], T)
    for i in range(L - 1, -1, -1):
        if has_next or i < L - 1:
            Phi = Phi_buf[i + 1]
            for a in range(n):
                acc = 0.0
                for b in range(n):
                    acc += Phi[b, a] * lam[b]
                tmp[a] = acc
            for a in range(n):
                lam[a] = tmp[a]
            propagate_info(Lam, Phi, U)
        P = P_buf[i]
        for a in range(n):
            acc = 0.0
            for b in range(n):
                acc += P[a, b] * lam[b]
            out_dx[i, a] = -acc
        # P^s = P - P Λ P, through M = Λ P, for the entries kept.
        for a in range(n):
            for b in range(n):
                acc = 0.0
                for c in range(n):
                    acc += Lam[a, c] * P[c, b]
                M[a, b] = acc
        for a in range(n):
            out.var[i, a] = P[a, a] - _row_dot(P, M, a, a)
        for a in range(6):
            for b in range(6):
                out.nav[i, a, b] = P[a, b] - _row_dot(P, M, a, b)
        for a in range(3):
            out.bias_cross[i, a] = P[X_BG + a, X_MG + a] - _row_dot(P, M, X_BG + a, X_MG + a)
            out.bias_cross[i, 3 + a] = P[X_BA + a, X_MA + a] - _row_dot(P, M, X_BA + a, X_MA + a)


def _row_dot_plain(P: FloatArray, M: FloatArray, a: int, b: int) -> float:  # pragma: no cover
    """``(P M)[a, b]``."""
    acc = 0.0
    for c in range(P.shape[0]):
        acc += P[a, c] * M[c, b]
    return acc


_row_dot = _jit(_row_dot_plain)
smooth_segment = cast(Callable[..., None], _jit(_smooth_segment))


def _mbf_update(
    Pm: FloatArray,
    H: FloatArray,
    r: FloatArray,
    z: FloatArray,
    nrows: int,
    lam: FloatArray,
    Lam: FloatArray,
) -> None:
    """Take ``λ^+``, ``Λ^+`` back through an update to ``λ^-``, ``Λ^-`` (in place).

    Plain numpy, not compiled: it runs once per checkpoint (a few small matrix
    products), where compiling it cost seconds on a user's first run (numba's matrix
    product and inverse) and saved milliseconds.
    """
    if nrows == 0:
        return
    Hp = H[:nrows]
    S = Hp @ Pm @ Hp.T
    for i in range(nrows):
        S[i, i] += r[i]
    Sinv = np.linalg.inv(S)
    Sinv = 0.5 * (Sinv + Sinv.T)
    K = Pm @ Hp.T @ Sinv
    Cm = np.eye(Pm.shape[0]) - K @ Hp
    HtSi = Hp.T @ Sinv
    new_lam = -(HtSi @ z[:nrows]) + Cm.T @ lam
    new_Lam = HtSi @ Hp + Cm.T @ Lam @ Cm
    lam[:] = new_lam
    Lam[:, :] = 0.5 * (new_Lam + new_Lam.T)


mbf_update = _mbf_update


def _ins_matrices(
    e: int,
    L: int,
    has_next: bool,
    t: FloatArray,
    gyro: FloatArray,
    acc: FloatArray,
    states: FloatArray,
    params: FloatArray,
    Phi_buf: FloatArray,
    q_buf: FloatArray,
    q_nav_buf: FloatArray,
) -> None:  # pragma: no cover - compiled by numba
    """``Φ`` and ``Q`` of the INS intervals ending at epochs ``e+1 .. e+L(-1)``."""
    n = Phi_buf.shape[1]
    C = np.empty((3, 3))
    F = np.zeros((n, n))
    w_b = np.empty(3)
    f_b = np.empty(3)
    top = L if has_next else L - 1
    ic = support_index(n)
    for i in range(1, top + 1):
        k = e + i
        step_matrices(
            states[k - 1], gyro[k], acc[k], t[k] - t[k - 1], t[k - 1], params, w_b, f_b, C,
            F, Phi_buf[i], q_buf[i], q_nav_buf[i],
        )  # fmt: skip
        if ic >= 0:  # the vertical support's transition, as the forward pass found it
            phi, qc = support_transition(states[k - 1, I_CVAR], states[k, I_CVAR])
            Phi_buf[i][ic, ic] = phi
            q_buf[i][ic] = qc


ins_matrices = cast(Callable[..., None], _jit(_ins_matrices))


def _apply_corrections(states: FloatArray, dx: FloatArray, k0: int) -> None:  # pragma: no cover
    """``states[k] ← states[k] ⊖ dx[k]`` for ``k >= k0`` (closed-loop feedback form)."""
    qa = np.empty(4)
    qb = np.empty(4)
    C = np.empty((3, 3))
    for k in range(k0, states.shape[0]):
        feedback(states[k], dx[k], qa, qb, C)


apply_corrections = cast(Callable[..., None], _jit(_apply_corrections))


def smooth_checkpoints(
    ck: Checkpoints,
    k_last: int,
    matrices: SegmentMatrices,
    done: SegmentDone,
    progress: Progress | None = None,
) -> None:
    """Backward pass over all checkpoints (generic in how ``Φ``, ``Q`` are produced).

    The smoothed errors and covariances are handed over one segment at a time
    (``done``), in buffers of the longest segment's length, so that the memory does not
    grow with the record beyond what the caller keeps.

    Parameters
    ----------
    ck : Checkpoints
        From the forward pass; ``ck.epoch[0]`` is the first epoch.
    k_last : int
        Last epoch (inclusive).
    matrices : SegmentMatrices
        Fills ``Φ`` and ``Q`` of the intervals inside a segment.
    done : SegmentDone
        Receives, segment by segment from the last, the smoothed error state
        (``true ≈ nominal ⊖ dx``) and its covariance entries at the segment's epochs;
        together they cover epochs ``ck.epoch[0] .. k_last``.
    progress : Progress, optional
        Fraction done (stage "smoother"), reported about every 10 000 epochs.
    """
    n = ck.P_plus.shape[1]
    seg = 2  # the longest segment, plus its next checkpoint's interval, plus one
    if ck.epoch.size:
        seg = int(np.max(np.diff(np.append(ck.epoch, k_last + 1)))) + 2
    Phi_buf = np.zeros((seg, n, n))
    q_buf = np.zeros((seg, n))
    q_nav_buf = np.zeros((seg, 6, 6))
    P_buf = np.zeros((seg, n, n))
    dx_buf = np.zeros((seg, n))
    cov_buf = new_smoothed_covariance(seg, n)
    lam = np.zeros(n)
    Lam = np.zeros((n, n))
    n_c = ck.epoch.size
    first = int(ck.epoch[0]) if n_c else 0
    total = max(1, k_last + 1 - first)
    reported = k_last + 1
    report(progress, 0.0, "smoother")
    for c in range(n_c - 1, -1, -1):
        e = int(ck.epoch[c])
        has_next = c < n_c - 1
        L = int(ck.epoch[c + 1]) - e if has_next else k_last + 1 - e
        if L > 0:
            matrices(e, L, has_next, Phi_buf, q_buf, q_nav_buf)
            segment = SmoothedCovariance(cov_buf.var[:L], cov_buf.nav[:L], cov_buf.bias_cross[:L])
            smooth_segment(
                ck.P_plus[c], Phi_buf, q_buf, q_nav_buf, L, has_next, lam, Lam,
                dx_buf[:L], segment, P_buf,
            )  # fmt: skip
            done(e, dx_buf[:L], segment)
        mbf_update(ck.P_minus[c], ck.H[c], ck.r[c], ck.z[c], int(ck.nrows[c]), lam, Lam)
        if reported - e >= 10_000:
            reported = e
            report(progress, (k_last + 1 - e) / total, "smoother")
    report(progress, 1.0, "smoother")


def _smoothed_std_rows(
    cov: SmoothedCovariance, states: FloatArray, k0: int, out: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """`kinsync.ins._ekf.solution_std` of every epoch from ``k0`` on, from ``cov``."""
    n = cov.var.shape[1]
    P = np.zeros((n, n))
    for k in range(k0, states.shape[0]):
        for a in range(n):
            P[a, a] = cov.var[k, a]
        for a in range(6):
            for b in range(6):
                P[a, b] = cov.nav[k, a, b]
        for a in range(3):
            P[X_BG + a, X_MG + a] = cov.bias_cross[k, a]
            P[X_BA + a, X_MA + a] = cov.bias_cross[k, 3 + a]
        solution_std(P, states[k], out[k])


smoothed_std_rows = cast(Callable[..., None], _jit(_smoothed_std_rows))


def smoothed_solution_std(cov: SmoothedCovariance, states: FloatArray, k0: int) -> FloatArray:
    """The solution's standard deviations (n_epochs, 21) from the smoothed covariance.

    ``states`` are the smoothed nominal states (the velocity error depends on the
    velocity); rows before ``k0`` are zero.
    """
    out = np.zeros((states.shape[0], N_OUT))
    smoothed_std_rows(cov, states, k0, out)
    return out


def smooth_forward_run(
    imu: ImuData, run: ForwardRun, progress: Progress | None = None, *, overwrite: bool = False
) -> tuple[FloatArray, FloatArray]:
    """Smoothed nominal states (n, 31) and the solution's 1σ (n, 21) of a forward run.

    Rows before ``run.k0`` are zero. Each segment's smoothed error and covariance are
    applied as soon as the backward pass has them, so that beside the two outputs the
    smoother keeps only the forward run's checkpoints and one segment's buffers.

    Parameters
    ----------
    imu : ImuData
        The IMU data the forward pass ran on.
    run : ForwardRun
        The forward pass, with its checkpoints.
    progress : Progress, optional
        Fraction done (stage "smoother").
    overwrite : bool
        Write the smoothed states and σ into ``run.states`` and ``run.std`` and return
        those arrays (the forward run is spent), instead of into new arrays: 52 floats
        less per epoch for a caller that keeps the forward solution elsewhere.
    """
    if run.checkpoints is None:
        msg = "smooth_forward_run: the forward pass was run without storing checkpoints"
        raise ValueError(msg)
    n = run.states.shape[0]
    t = imu.t_s
    gyro = imu.gyro_body_rad_s
    acc = imu.acc_body_m_s2
    states = run.states
    params = run.params
    # In place, a segment's rows are corrected after its Φ and Q were built from them;
    # the segment before it then reads only the vertical support's stored variance
    # (I_CVAR) of its first row, which the correction leaves as it is (`feedback`).
    out = run.states if overwrite else np.array(run.states, dtype=np.float64)
    std = run.std if overwrite else np.zeros((n, N_OUT))
    if overwrite:  # rows before k0 are zero, as in new arrays
        out[: run.k0] = 0.0
        std[: run.k0] = 0.0

    def fill(
        e: int, L: int, has_next: bool, Phi_buf: FloatArray, q_buf: FloatArray, q_nav: FloatArray
    ) -> None:
        ins_matrices(e, L, has_next, t, gyro, acc, states, params, Phi_buf, q_buf, q_nav)

    def done(e: int, dx: FloatArray, cov: SmoothedCovariance) -> None:
        rows = out[e : e + dx.shape[0]]
        apply_corrections(rows, dx, 0)
        smoothed_std_rows(cov, rows, 0, std[e : e + dx.shape[0]])

    smooth_checkpoints(run.checkpoints, n - 1, fill, done, progress)
    return out, std
