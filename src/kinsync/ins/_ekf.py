"""Compiled pieces of the 15-state error-state filter shared by the filter and smoother.

Error state (all in the local NED frame of the nominal state, SI units)::

    x = [φ (3), δv (3), δp (3), δb_g (3), δb_a (3)]

- ``φ``: misorientation (rad) with ``C_b^n(nominal) = (I - [φ×]) C_b^n(true)``;
- ``δv = v(nominal) - v(true)`` (m/s, NED);
- ``δp``: position error in metres North, East, Down:
  ``δp_N = (R_M + h) δlat``, ``δp_E = (R_N + h) cos(lat) δlon``, ``δp_D = -δh``.
  Metres rather than radians keep the covariance well scaled and make the GNSS
  observation matrix a plain identity;
- ``δb_g = b_g(true) - b_g(estimate)``, ``δb_a`` likewise: the residual sensor
  biases, first-order Gauss–Markov (``δḃ = -δb/τ + w``).

Continuous model ``ẋ = F x + G w`` (Titterton & Weston 2004, ch. 12; Groves 2013,
ch. 14, rewritten for metric position errors)::

    φ̇  = -[ω_in×] φ + δω_in - C_b^n δb_g - C_b^n w_g
    δv̇ = [f^n×] φ + C_b^n δb_a - [(2ω_ie + ω_en)×] δv + [v×](2δω_ie + δω_en) + δg + C_b^n w_a
    δṗ = δv + (terms of order v/R)

``Φ = I + FΔt + F²Δt²/2`` and ``Q = G Q_c G^T Δt``; with isotropic white noise the
rotation ``C_b^n`` drops out and ``Q`` is diagonal. ``F`` has zero rows below the
navigation block except the bias decay on the diagonal, so ``Φ`` is
``[[A (9×9), B (9×6)], [0, D (6, diagonal)]]`` and ``Φ P Φ^T`` costs about 2 800
multiply-adds instead of 6 750.

Closed-loop feedback (``_feedback``) applies ``true ≈ nominal ⊖ x``: attitude
``q ← q(φ) ⊗ q``, ``v ← v - δv``, position back to latitude/longitude/height, bias
estimates ``+= δb``; the error state is then zero again.

References
----------
D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed.,
IET 2004, ch. 12 (error equations). P. D. Groves, *Principles of GNSS, Inertial, and
Multisensor Integrated Navigation Systems*, 2nd ed., Artech House, 2013, ch. 14
(INS/GNSS state propagation and lever-arm measurement models).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, cast

from numba import njit

from kinsync._typing import FloatArray
from kinsync.ins.earth import A_M, E2, OMEGA_IE_RAD_S, normal_gravity_m_s2
from kinsync.ins.strapdown import (
    I_BA,
    I_BG,
    I_H,
    I_LAT,
    I_LON,
    I_Q,
    I_VEL,
    quat_mul,
    quat_to_dcm,
    rotvec_to_quat,
)

_jit = cast(Callable[[Callable[..., Any]], Callable[..., Any]], njit(cache=True))

N_ERR = 15
N_NAV = 9  # attitude, velocity, position: the dense block of F and Φ

# Parameter vector of the filter (one float64 array passed to the compiled loop).
P_TAU_G, P_TAU_A = 0, 1  # Gauss–Markov correlation times (s)
P_QC_ATT, P_QC_VEL = 2, 3  # white-noise PSDs: arw^2 (rad^2/s), vrw^2 (m^2/s^3)
P_QC_BG, P_QC_BA = 4, 5  # bias driving-noise PSDs 2σ²/τ
P_ARM = 6  # 6..8 antenna lever arm, body (m)
P_GATE = 9  # χ² threshold, 3 degrees of freedom
P_USE_VEL = 10  # 1.0: use GNSS velocities
N_PARAMS = 11


def _build_F(  # noqa: PLR0915 - one flat function is what numba compiles best
    s: FloatArray, f_b: FloatArray, tau_g: float, tau_a: float, C: FloatArray, F: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """Fill ``F`` (15, 15) for the nominal state ``s`` and bias-corrected specific force.

    ``C`` (3, 3) receives ``C_b^n`` of the state. Only the navigation rows and the
    bias diagonal are written; callers keep the other entries zero.
    """
    lat = s[I_LAT]
    h = s[I_H]
    vn, ve, vd = s[I_VEL], s[I_VEL + 1], s[I_VEL + 2]
    sl = math.sin(lat)
    cl = math.cos(lat)
    tl = sl / cl
    den = 1.0 - E2 * sl * sl
    r_n = A_M / math.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * math.sqrt(den))
    rmh = r_m + h
    rnh = r_n + h
    om = OMEGA_IE_RAD_S
    wie0, wie2 = om * cl, -om * sl
    wen0, wen1, wen2 = ve / rnh, -vn / rmh, -ve * tl / rnh
    win0, win1, win2 = wie0 + wen0, wen1, wie2 + wen2
    quat_to_dcm(s[I_Q : I_Q + 4], C)
    fn0 = C[0, 0] * f_b[0] + C[0, 1] * f_b[1] + C[0, 2] * f_b[2]
    fn1 = C[1, 0] * f_b[0] + C[1, 1] * f_b[1] + C[1, 2] * f_b[2]
    fn2 = C[2, 0] * f_b[0] + C[2, 1] * f_b[1] + C[2, 2] * f_b[2]

    # Derivatives of ω_ie and ω_en with respect to δv and δp (3x3 each, row = component).
    # δω_ie = Ω (-sin, 0, -cos) δp_N / (R_M + h)
    die00 = -om * sl / rmh
    die20 = -om * cl / rmh
    # δω_en / δv
    dv01 = 1.0 / rnh
    dv10 = -1.0 / rmh
    dv21 = -tl / rnh
    # δω_en / δp
    dp02 = ve / (rnh * rnh)
    dp12 = -vn / (rmh * rmh)
    dp20 = -ve / (cl * cl * rnh * rmh)
    dp22 = -ve * tl / (rnh * rnh)

    # Attitude rows.
    F[0, 0] = 0.0
    F[0, 1] = win2
    F[0, 2] = -win1
    F[1, 0] = -win2
    F[1, 1] = 0.0
    F[1, 2] = win0
    F[2, 0] = win1
    F[2, 1] = -win0
    F[2, 2] = 0.0
    F[0, 3], F[0, 4], F[0, 5] = 0.0, dv01, 0.0
    F[1, 3], F[1, 4], F[1, 5] = dv10, 0.0, 0.0
    F[2, 3], F[2, 4], F[2, 5] = 0.0, dv21, 0.0
    F[0, 6], F[0, 7], F[0, 8] = die00, 0.0, dp02
    F[1, 6], F[1, 7], F[1, 8] = 0.0, 0.0, dp12
    F[2, 6], F[2, 7], F[2, 8] = die20 + dp20, 0.0, dp22
    for i in range(3):
        for j in range(3):
            F[i, 9 + j] = -C[i, j]
            F[i, 12 + j] = 0.0
            F[3 + i, 9 + j] = 0.0
            F[3 + i, 12 + j] = C[i, j]
            F[6 + i, 9 + j] = 0.0
            F[6 + i, 12 + j] = 0.0
            F[6 + i, j] = 0.0

    # Velocity rows: [f^n×] φ.
    F[3, 0], F[3, 1], F[3, 2] = 0.0, -fn2, fn1
    F[4, 0], F[4, 1], F[4, 2] = fn2, 0.0, -fn0
    F[5, 0], F[5, 1], F[5, 2] = -fn1, fn0, 0.0
    # -[(2ω_ie + ω_en)×] δv + [v×] (δω_en/δv) δv
    c0, c1, c2 = 2.0 * wie0 + wen0, wen1, 2.0 * wie2 + wen2
    # [v×] = [[0, -vd, ve], [vd, 0, -vn], [-ve, vn, 0]]
    F[3, 3] = 0.0 + (-vd * dv10)
    F[3, 4] = c2 + (0.0 * dv01 + ve * dv21)
    F[3, 5] = -c1
    F[4, 3] = -c2
    F[4, 4] = 0.0 + (vd * dv01 - vn * dv21)
    F[4, 5] = c0
    F[5, 3] = c1 + (vn * dv10)
    F[5, 4] = -c0 + (-ve * dv01)
    F[5, 5] = 0.0
    # [v×] (2 δω_ie + δω_en) / δp, plus the vertical gravity gradient 2g/R δp_D.
    a00 = 2.0 * die00
    a20 = 2.0 * die20 + dp20
    a02 = dp02
    a12 = dp12
    a22 = dp22
    F[3, 6] = -vd * 0.0 + ve * a20
    F[3, 7] = 0.0
    F[3, 8] = -vd * a12 + ve * a22
    F[4, 6] = vd * a00 - vn * a20
    F[4, 7] = 0.0
    F[4, 8] = vd * a02 - vn * a22
    F[5, 6] = -ve * a00
    F[5, 7] = 0.0
    F[5, 8] = -ve * a02 + vn * a12 + 2.0 * normal_gravity_m_s2(lat, h) / math.sqrt(r_m * r_n)
    # Position rows (metric errors).
    F[6, 3], F[6, 4], F[6, 5] = 1.0, 0.0, 0.0
    F[7, 3], F[7, 4], F[7, 5] = 0.0, 1.0, 0.0
    F[8, 3], F[8, 4], F[8, 5] = 0.0, 0.0, 1.0
    F[6, 6], F[6, 7], F[6, 8] = -vd / rmh, 0.0, vn / rmh
    F[7, 6], F[7, 7], F[7, 8] = ve * tl / rmh, -(vd / rnh + vn * tl / rmh), ve / rnh
    F[8, 6], F[8, 7], F[8, 8] = 0.0, 0.0, 0.0
    # Bias rows: Gauss–Markov decay.
    for i in range(3):
        F[9 + i, 9 + i] = -1.0 / tau_g
        F[12 + i, 12 + i] = -1.0 / tau_a


def _phi_from_F(F: FloatArray, dt: float, Phi: FloatArray) -> None:  # pragma: no cover
    """``Φ = I + FΔt + F²Δt²/2`` exploiting the block structure of ``F`` (see module)."""
    half = 0.5 * dt * dt
    for i in range(N_NAV):
        for j in range(N_ERR):
            acc = 0.0
            for m in range(N_NAV):
                acc += F[i, m] * F[m, j]
            if j >= N_NAV:
                acc += F[i, j] * F[j, j]
            Phi[i, j] = F[i, j] * dt + acc * half
        Phi[i, i] += 1.0
    for i in range(N_NAV, N_ERR):
        for j in range(N_ERR):
            Phi[i, j] = 0.0
        d = F[i, i]
        Phi[i, i] = 1.0 + d * dt + d * d * half


def _propagate_cov(
    P: FloatArray, Phi: FloatArray, qdiag: FloatArray, T: FloatArray
) -> None:  # pragma: no cover
    """``P ← Φ P Φ^T + diag(q)`` in place for a block-structured ``Φ``; ``T`` is (9, 15)."""
    for i in range(N_NAV):
        for j in range(N_ERR):
            acc = 0.0
            for m in range(N_ERR):
                acc += Phi[i, m] * P[m, j]
            T[i, j] = acc
    for i in range(N_NAV):
        for j in range(i, N_NAV):
            acc = 0.0
            for m in range(N_ERR):
                acc += T[i, m] * Phi[j, m]
            P[i, j] = acc
            P[j, i] = acc
        P[i, i] += qdiag[i]
        for b in range(N_NAV, N_ERR):
            v = T[i, b] * Phi[b, b]
            P[i, b] = v
            P[b, i] = v
    for a in range(N_NAV, N_ERR):
        for b in range(a, N_ERR):
            v = Phi[a, a] * P[a, b] * Phi[b, b]
            P[a, b] = v
            P[b, a] = v
        P[a, a] += qdiag[a]


def _scalar_update(
    P: FloatArray, x: FloatArray, h: FloatArray, r: float, z: float, ph: FloatArray
) -> None:  # pragma: no cover
    """Kalman update with one scalar measurement ``z = h·x + v``, ``var(v) = r``.

    ``x`` (15,) and ``P`` (15, 15) are updated in place (symmetric form
    ``P ← P - (Ph)(Ph)^T / s``); ``ph`` (15,) is scratch.
    """
    for i in range(N_ERR):
        acc = 0.0
        for j in range(N_ERR):
            acc += P[i, j] * h[j]
        ph[i] = acc
    s = r
    nu = z
    for i in range(N_ERR):
        s += h[i] * ph[i]
        nu -= h[i] * x[i]
    for i in range(N_ERR):
        k = ph[i] / s
        x[i] += k * nu
        for j in range(i, N_ERR):
            v = P[i, j] - k * ph[j]
            P[i, j] = v
            P[j, i] = v


def _feedback(
    s: FloatArray, x: FloatArray, qa: FloatArray, qb: FloatArray
) -> None:  # pragma: no cover
    """Correct the nominal state ``s`` with the error state ``x`` (``true ≈ s ⊖ x``)."""
    lat = s[I_LAT]
    h = s[I_H]
    sl = math.sin(lat)
    den = 1.0 - E2 * sl * sl
    r_n = A_M / math.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * math.sqrt(den))
    rotvec_to_quat(x[0], x[1], x[2], qa)
    quat_mul(qa, s[I_Q : I_Q + 4], qb)
    nq = math.sqrt(qb[0] ** 2 + qb[1] ** 2 + qb[2] ** 2 + qb[3] ** 2)
    for i in range(4):
        s[I_Q + i] = qb[i] / nq
    for i in range(3):
        s[I_VEL + i] -= x[3 + i]
        s[I_BG + i] += x[9 + i]
        s[I_BA + i] += x[12 + i]
    s[I_LAT] = lat - x[6] / (r_m + h)
    s[I_LON] -= x[7] / ((r_n + h) * math.cos(lat))
    s[I_H] = h + x[8]


def _qdiag(params: FloatArray, dt: float, q: FloatArray) -> None:  # pragma: no cover
    """Diagonal of the discrete process noise ``Q`` for an interval ``dt``."""
    for i in range(3):
        q[i] = params[P_QC_ATT] * dt
        q[3 + i] = params[P_QC_VEL] * dt
        q[6 + i] = 0.0
        q[9 + i] = params[P_QC_BG] * dt
        q[12 + i] = params[P_QC_BA] * dt


def _step_matrices(
    s: FloatArray,
    acc: FloatArray,
    dt: float,
    params: FloatArray,
    f_b: FloatArray,
    C: FloatArray,
    F: FloatArray,
    Phi: FloatArray,
    q: FloatArray,
) -> None:  # pragma: no cover
    """``Φ`` and ``diag(Q)`` of the interval ending at an IMU sample (state at its start)."""
    for i in range(3):
        f_b[i] = acc[i] - s[I_BA + i]
    system_matrix(s, f_b, params[P_TAU_G], params[P_TAU_A], C, F)
    transition_from_system(F, dt, Phi)
    qdiag(params, dt, q)


system_matrix = _jit(_build_F)
transition_from_system = _jit(_phi_from_F)
propagate_cov = _jit(_propagate_cov)
scalar_update = _jit(_scalar_update)
feedback = _jit(_feedback)
qdiag = _jit(_qdiag)
step_matrices = _jit(_step_matrices)
