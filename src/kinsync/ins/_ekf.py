"""Compiled pieces of the error-state filter shared by the filter and the smoother.

Error state (local NED frame of the nominal state, SI units), 21 states, or 27 with
scale factors, plus one after a levelled standstill (22 or 28)::

    x = [φ (3), δv' (3), δp (3), δb_g (3), δb_a (3), δm_g (3), δm_a (3), [δs_g (3), δs_a (3)],
         [δc]]

- ``φ``: misorientation (rad) with ``C_b^n(nominal) = (I - [φ×]) C_b^n(true)``;
- ``δv'``: the velocity error of the *modified φ-angle* model (Scherzinger & Reid
  1994): the nominal velocity minus the true velocity resolved in the nominal
  ("platform") frame, ``δv' = δv - [v×] φ`` with ``δv = v(nominal) - v(true)``.
  The specific force leaves the system matrix (``δv̇'`` sees gravity, not ``f``), so the
  model stays accurate for heading errors of tens of degrees, which a filter whose
  turn-on gyro bias is still unknown meets early in a run; the correction rotates the
  velocity with the attitude;
- ``δp``: position error in metres North, East, Down:
  ``δp_N = (R_M + h) δlat``, ``δp_E = (R_N + h) cos(lat) δlon``, ``δp_D = -δh``.
  Metres rather than radians keep the covariance well scaled and make the GNSS
  observation matrix a plain identity;
- sensor errors, each ``true - estimate`` in the body frame, the way a datasheet states
  them: ``δb``, the **turn-on bias** (a random constant; initial σ from the turn-on
  figure, or the σ of a laboratory calibration), ``δm``, the **in-run bias
  instability** (first-order Gauss–Markov: ``δṁ = -δm/τ + w``, steady σ and ``τ`` from
  the datasheet), and optionally ``δs``, the **scale factor** errors (random constants,
  dimensionless). The sensor error of a corrected sample is
  ``δω = δb_g + δm_g + diag(ω) δs_g`` (``δf`` likewise). Turn-on bias and instability
  are separate states because one Gauss–Markov state for both decays its variance
  from the turn-on σ to the instability σ within ``τ/2``: the filter then treats an
  unobserved 0.2 deg/s turn-on bias as known to the instability (6.5 deg/h);
- ``δc``: the second-order vertical support of the tilt (m/s², below), only when the
  run starts with a levelled standstill (`support_index`).

Continuous model ``ẋ = F x + G w`` (Scherzinger & Reid 1994, as in Groves 2013,
ch. 14, for metric position errors; ``R`` is the curvature matrix with
``ω_en = R v``)::

    δṗ  = δv' + [v×] φ + (terms of order v/R)
    δv̇' = -[(2ω_ie + ω_en)×] δv' - [g×] φ + (2g/R) δp_D e_D + [v×] C_b^n δω + C_b^n δf
    φ̇  = [ω_ie×] R δp + R δv' + (R [v×] - [(ω_ie + ω_en)×]) φ - C_b^n δω

``Φ = I + FΔt + F²Δt²/2`` and ``Q = G Q_c G^T Δt``. The white sensor noise enters the
attitude and velocity rows through ``-C`` and ``[v×] C``, so ``Q`` has a dense 6×6
navigation block (`process_noise`) and a diagonal for the Gauss–Markov states. ``F``
has zero rows below the navigation block except the Gauss–Markov decay on the
diagonal, so ``Φ`` is ``[[A (9×9), B (9×m)], [0, D (m, diagonal)]]`` and ``Φ P Φ^T``
is computed block by block.

Second-order mean of the tilt error (`tilt_gravity_mean`). The gravity term of
``δv̇'`` is ``(I - Rot(φ)^T) g``; its first-order part ``-[g×] φ`` has zero mean, but
its second-order part ``-½ [φ×]² g`` does not: an uncertain tilt always lowers the
vertical support the mechanisation computes from the sensed specific force (by
``½ g θ²`` for a tilt error θ). Its expectation over ``φ ~ N(0, P_φφ)`` is
``-½ (P_φφ - tr(P_φφ) I) g``, i.e. ``(-½ g P_ND, -½ g P_ED, ½ g (P_NN + P_EE))``; it is
removed from the nominal velocity at every epoch, as the Gaussian second-order filter
does (Gelb 1974, sec. 6.1). It matters only while the tilt σ is large, e.g. 1-3 deg
when unknown turn-on gyro biases meet the first turns of a run: left in the
mechanisation it is learned as an accelerometer bias the filter then believes to
0.1 mg (on simulated NaveGo-like drives the normalised vertical accelerometer bias
error was 1.7 over 60-200 s, and the height RMS 4 % higher).

First-estimates Jacobian during the initial standstill (`step_matrices`). At rest
the levelled tilt and the horizontal accelerometer error are one unobservable direction
(``g φ_h = (C δb)_h``, `kinsync.ins.filter.initial_covariance`). The accelerometer
columns ``C`` of ``F`` depend on the estimated attitude, and the GNSS updates move that
estimate along the unobservable direction (1° of roll over a minute); re-linearising
about each new estimate turns the vertical accelerometer error, which the height
observes, into information on the tilt that the data do not hold: the filter's tilt σ
fell from 0.91° to 0.59° in 50 s at rest while the error stayed at 0.85° (12 simulated
MEMS static starts). Keeping the levelled attitude in those columns until the vehicle
moves (the observability-preserving choice of Huang, Mourikis and Roumeliotis 2008)
keeps it at 0.91°. Once the vehicle moves the tilt is observable and the state's
attitude is used again.

Second-order vertical support of the tilt (``c``, `kinsync.ins.standstill`): the
vertical part of ``-½ [φ×]² g``, ``c = ½ g |φ_h|²`` for the tilt error ``φ_h`` (North,
East), as an error state. The tilt mean above removes its expectation and leaves the
rest, which is harmless while the tilt is independent of the other errors. After a
static alignment it is not: levelling makes the resolved specific force exactly
vertical, the tilt is the horizontal accelerometer error ``δf_h`` over g, and at rest
the down velocity sees ``δv̇'_D = (C δf)_D + c`` with ``c = |δf_h|²/(2g)`` (0.25 mg on
average for the MEMS preset, and as much again from run to run) against the model
linearised about the levelled attitude. At rest ``c`` drives the height as a vertical
accelerometer bias does; left out, the accelerometer states took it with their own σ
(the smoothed vertical bias at rest off by 0.28 mg RMS against a σ of 0.022 mg, 12
simulated MEMS static starts). So, after a levelled standstill only, ``c`` is the last
error state: its column of ``F`` is ``e_D`` in the velocity rows (`step_matrices`),
``δc = c - ĉ`` like a sensor error, and the estimate ``ĉ`` is part of the nominal state
(``I_CV``), removed from the down velocity at every epoch in place of the tilt mean's
vertical term (`remove_support`).

Its dynamics come from the filter's own tilt covariance ``P_h`` (`propagate_support`).
For ``φ_h ~ N(0, P_h)``, ``c`` has the mean ``m = ½ g tr(P_h)`` and the variance
``v = ½ g² tr(P_h²)`` (`tilt_moments`). The tilt error left after more data is
independent of the correction those data made, so ``cov(c(t1), c(t2)) = v(t2)`` for
``t1 < t2`` while the tilt is being observed, and ``c`` gains ``v2 - v1`` while the
tilt covariance grows: between two epochs ``c - m`` has the transition
``Φ_cc = min(1, v2/v1)`` and the noise ``Q_cc = v2 - Φ_cc² v1`` (`support_transition`),
and ``ĉ ← m2 + Φ_cc (ĉ - m1)``. The moments are those of the covariance before each
epoch's updates, stored in the nominal state (``I_CM``, ``I_CVAR``) so that the smoother
rebuilds the same ``Φ`` and ``Q``. While the vehicle stands, ``P_h`` stays as levelling
left it and ``c`` is a random constant; once the turns make the tilt observable it
fades with ``v``, as the true term does. (Made inert at the drive-off instead, the
term the filter had not yet observed away went to the bias instability: smoothed
vertical bias error over its σ of RMS 2.3 at rest and 4-6 over 60-85 s. Scaled with
``tr(P_h)`` and never decorrelated, 0.9 at rest and 1.8-4.4 over 60-85 s.)

Closed-loop feedback (``_feedback``) applies ``true ≈ nominal ⊖ x``: attitude
``q ← q(φ) ⊗ q``, velocity ``v ← Rot(φ) (v - δv')``, position back to latitude,
longitude and height, sensor estimates ``+= δb, δm, δs`` (and ``ĉ += δc``); the error
state is then zero again. Between updates the instability estimate decays as its model says
(``m ← m e^{-Δt/τ}``, `kinsync.ins.strapdown`).

References
----------
A. Gelb (ed.), *Applied Optimal Estimation*, MIT Press 1974, sec. 6.1 (the second-order
filter's mean correction ``½ tr(∂²f/∂x² P)``).
G. P. Huang, A. I. Mourikis, S. I. Roumeliotis, "Analysis and improvement of the
consistency of extended Kalman filter based SLAM", Proc. IEEE ICRA 2008, 473-479
(first-estimates Jacobian).
B. M. Scherzinger, D. B. Reid, "Modified strapdown inertial navigator error models",
Proc. IEEE PLANS 1994, 426-430 (the modified φ-angle model).
D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed.,
IET 2004, ch. 12 (error equations). P. D. Groves, *Principles of GNSS, Inertial, and
Multisensor Integrated Navigation Systems*, 2nd ed., Artech House, 2013, ch. 14
(INS/GNSS state propagation and lever-arm measurement models) and ch. 4 (sensor error
models: fixed bias, bias instability, scale factor).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray
from kinsync.ins.earth import A_M, E2, OMEGA_IE_RAD_S, normal_gravity_m_s2
from kinsync.ins.strapdown import (
    I_BA,
    I_BG,
    I_CM,
    I_CV,
    I_CVAR,
    I_H,
    I_LAT,
    I_LON,
    I_MA,
    I_MG,
    I_Q,
    I_SA,
    I_SG,
    I_VEL,
    quat_mul,
    quat_to_dcm,
    rotvec_to_quat,
)

_jit = cached_njit()

N_NAV = 9  # attitude, velocity, position: the dense block of F and Φ
X_BG, X_BA = 9, 12  # turn-on biases (random constants)
X_MG, X_MA = 15, 18  # bias instabilities (Gauss–Markov)
X_SG, X_SA = 21, 24  # scale factors (random constants), optional
N_ERR = 21
"""Error states without scale factors."""
N_ERR_SCALE = 27
"""Error states with gyro and accelerometer scale factors."""
N_SUPPORT = 1
"""Error states added after a levelled standstill: ``δc``, the last one."""
N_OUT = 21
"""Standard deviations per epoch in the solution (`solution_std`): attitude (rad),
velocity (m/s), position (m) errors, total gyro (rad/s) and accelerometer (m/s^2) bias,
gyro and accelerometer scale factor (NaN when not modelled)."""

# Parameter vector of the filter (one float64 array passed to the compiled loop).
P_TAU_G, P_TAU_A = 0, 1  # Gauss–Markov correlation times (s)
P_QC_ATT, P_QC_VEL = 2, 3  # white-noise PSDs: arw^2 (rad^2/s), vrw^2 (m^2/s^3)
P_QC_BG, P_QC_BA = 4, 5  # instability driving-noise PSDs 2σ²/τ
P_ARM = 6  # 6..8 antenna lever arm, body (m)
P_GATE = 9  # χ² threshold, 3 degrees of freedom
P_USE_VEL = 10  # 1.0: use GNSS velocities
P_TILT_MEAN = 11  # 1.0: remove the second-order tilt mean (`tilt_gravity_mean`)
P_FEJ_END = 12  # end of the initial standstill (s); -inf: none (`step_matrices`)
P_FEJ_C = 13  # 13..21 the levelled C_b^n, row by row, used until P_FEJ_END
N_PARAMS = 22


def _support_index(n: int) -> int:  # pragma: no cover - compiled by numba
    """Index of ``δc`` in an error state of ``n`` entries, -1 without it.

    ``n`` is 21 or 27 (with scale factors), plus `N_SUPPORT` after a levelled
    standstill; scale factors are modelled when ``n >= N_ERR_SCALE``.
    """
    if n == N_ERR + N_SUPPORT or n == N_ERR_SCALE + N_SUPPORT:
        return n - 1
    return -1


support_index = cast(Callable[[int], int], _jit(_support_index))


def _corrected_imu(
    s: FloatArray, gyro: FloatArray, acc: FloatArray, w_b: FloatArray, f_b: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """``w_b``, ``f_b`` (3,): the sample corrected with the state's sensor estimates.

    ``ω = (ω_measured - b_g - m_g) / (1 + s_g)``; likewise the specific force.
    """
    for i in range(3):
        w_b[i] = (gyro[i] - s[I_BG + i] - s[I_MG + i]) / (1.0 + s[I_SG + i])
        f_b[i] = (acc[i] - s[I_BA + i] - s[I_MA + i]) / (1.0 + s[I_SA + i])


def _build_F(  # noqa: PLR0915 - one flat function is what numba compiles best
    s: FloatArray,
    w_b: FloatArray,
    f_b: FloatArray,
    tau_g: float,
    tau_a: float,
    C: FloatArray,
    F: FloatArray,
) -> None:  # pragma: no cover - compiled by numba
    """Fill ``F`` (n, n) for the nominal state ``s`` and the corrected sample ``w_b, f_b``.

    ``C`` (3, 3) receives ``C_b^n`` of the state. Only the navigation rows and the
    Gauss–Markov diagonal are written; callers keep the other entries zero (``δc``'s
    column is `step_matrices`'). ``n`` (21 or 27, with scale factors, plus
    `N_SUPPORT`) is ``F``'s size.
    """
    n = F.shape[0]
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
    # Curvature matrix R (ω_en = R v): R[0,1] = 1/(R_N+h), R[1,0] = -1/(R_M+h),
    # R[2,1] = -tan(lat)/(R_N+h).
    r01, r10, r21 = 1.0 / rnh, -1.0 / rmh, -tl / rnh
    wen0, wen1, wen2 = r01 * ve, r10 * vn, r21 * ve
    g = normal_gravity_m_s2(lat, h)
    quat_to_dcm(s[I_Q : I_Q + 4], C)

    # Attitude rows. φ/δp = [ω_ie×] R, φ/δv' = R, φ/φ = R [v×] - [(ω_ie + ω_en)×].
    # [ω_ie×] = [[0, -wie2, 0], [wie2, 0, -wie0], [0, wie0, 0]]
    F[0, 6], F[0, 7], F[0, 8] = -wie2 * r10, 0.0, 0.0
    F[1, 6], F[1, 7], F[1, 8] = 0.0, wie2 * r01 - wie0 * r21, 0.0
    F[2, 6], F[2, 7], F[2, 8] = wie0 * r10, 0.0, 0.0
    F[0, 3], F[0, 4], F[0, 5] = 0.0, r01, 0.0
    F[1, 3], F[1, 4], F[1, 5] = r10, 0.0, 0.0
    F[2, 3], F[2, 4], F[2, 5] = 0.0, r21, 0.0
    # R [v×] with [v×] = [[0, -vd, ve], [vd, 0, -vn], [-ve, vn, 0]]
    w0, w1, w2 = wie0 + wen0, wen1, wie2 + wen2
    F[0, 0], F[0, 1], F[0, 2] = r01 * vd, 0.0 + w2, -r01 * vn - w1
    F[1, 0], F[1, 1], F[1, 2] = 0.0 - w2, -r10 * vd, r10 * ve + w0
    F[2, 0], F[2, 1], F[2, 2] = r21 * vd + w1, -w0, -r21 * vn
    # Velocity rows. δv'/δv' = -[(2ω_ie + ω_en)×], δv'/φ = -[g×], gravity gradient.
    c0, c1, c2 = 2.0 * wie0 + wen0, wen1, 2.0 * wie2 + wen2
    F[3, 3], F[3, 4], F[3, 5] = 0.0, c2, -c1
    F[4, 3], F[4, 4], F[4, 5] = -c2, 0.0, c0
    F[5, 3], F[5, 4], F[5, 5] = c1, -c0, 0.0
    F[3, 0], F[3, 1], F[3, 2] = 0.0, g, 0.0
    F[4, 0], F[4, 1], F[4, 2] = -g, 0.0, 0.0
    F[5, 0], F[5, 1], F[5, 2] = 0.0, 0.0, 0.0
    for j in range(6, 9):
        F[3, j] = 0.0
        F[4, j] = 0.0
        F[5, j] = 0.0
    F[5, 8] = 2.0 * g / math.sqrt(r_m * r_n)
    # Position rows (metric errors): δp = δv' + [v×] φ + (v/R terms).
    F[6, 0], F[6, 1], F[6, 2] = 0.0, -vd, ve
    F[7, 0], F[7, 1], F[7, 2] = vd, 0.0, -vn
    F[8, 0], F[8, 1], F[8, 2] = -ve, vn, 0.0
    F[6, 3], F[6, 4], F[6, 5] = 1.0, 0.0, 0.0
    F[7, 3], F[7, 4], F[7, 5] = 0.0, 1.0, 0.0
    F[8, 3], F[8, 4], F[8, 5] = 0.0, 0.0, 1.0
    F[6, 6], F[6, 7], F[6, 8] = -vd / rmh, 0.0, vn / rmh
    F[7, 6], F[7, 7], F[7, 8] = ve * tl / rmh, -(vd / rnh + vn * tl / rmh), ve / rnh
    F[8, 6], F[8, 7], F[8, 8] = 0.0, 0.0, 0.0
    # Sensor columns: gyro errors through -C (attitude) and [v×] C (velocity),
    # accelerometer errors through C (velocity).
    for i in range(3):
        vc0 = -vd * C[1, i] + ve * C[2, i]
        vc1 = vd * C[0, i] - vn * C[2, i]
        vc2 = -ve * C[0, i] + vn * C[1, i]
        for col in (X_BG + i, X_MG + i):
            F[0, col], F[1, col], F[2, col] = -C[0, i], -C[1, i], -C[2, i]
            F[3, col], F[4, col], F[5, col] = vc0, vc1, vc2
            F[6, col], F[7, col], F[8, col] = 0.0, 0.0, 0.0
        for col in (X_BA + i, X_MA + i):
            F[0, col], F[1, col], F[2, col] = 0.0, 0.0, 0.0
            F[3, col], F[4, col], F[5, col] = C[0, i], C[1, i], C[2, i]
            F[6, col], F[7, col], F[8, col] = 0.0, 0.0, 0.0
        if n >= N_ERR_SCALE:
            col = X_SG + i
            F[0, col], F[1, col], F[2, col] = (
                -C[0, i] * w_b[i],
                -C[1, i] * w_b[i],
                -C[2, i] * w_b[i],
            )
            F[3, col], F[4, col], F[5, col] = vc0 * w_b[i], vc1 * w_b[i], vc2 * w_b[i]
            F[6, col], F[7, col], F[8, col] = 0.0, 0.0, 0.0
            col = X_SA + i
            F[0, col], F[1, col], F[2, col] = 0.0, 0.0, 0.0
            F[3, col], F[4, col], F[5, col] = C[0, i] * f_b[i], C[1, i] * f_b[i], C[2, i] * f_b[i]
            F[6, col], F[7, col], F[8, col] = 0.0, 0.0, 0.0
    # Sensor rows: Gauss–Markov decay of the instabilities; constants do not move.
    for i in range(3):
        F[X_MG + i, X_MG + i] = -1.0 / tau_g
        F[X_MA + i, X_MA + i] = -1.0 / tau_a


def _phi_from_F(F: FloatArray, dt: float, Phi: FloatArray) -> None:  # pragma: no cover
    """``Φ = I + FΔt + F²Δt²/2`` exploiting the block structure of ``F`` (see module)."""
    n = F.shape[0]
    half = 0.5 * dt * dt
    for i in range(N_NAV):
        for j in range(n):
            acc = 0.0
            for m in range(N_NAV):
                acc += F[i, m] * F[m, j]
            if j >= N_NAV:
                acc += F[i, j] * F[j, j]
            Phi[i, j] = F[i, j] * dt + acc * half
        Phi[i, i] += 1.0
    for i in range(N_NAV, n):
        for j in range(n):
            Phi[i, j] = 0.0
        d = F[i, i]
        Phi[i, i] = 1.0 + d * dt + d * d * half


def _propagate_cov(
    P: FloatArray, Phi: FloatArray, q: FloatArray, q_nav: FloatArray, T: FloatArray
) -> None:  # pragma: no cover
    """``P ← Φ P Φ^T + Q`` in place for a block-structured ``Φ``.

    ``Q`` is ``diag(q)`` (n,) plus the dense 6×6 attitude-velocity block ``q_nav``;
    ``T`` is (9, n) scratch.
    """
    n = P.shape[0]
    for i in range(N_NAV):
        for j in range(n):
            acc = 0.0
            for m in range(n):
                acc += Phi[i, m] * P[m, j]
            T[i, j] = acc
    for i in range(N_NAV):
        for j in range(i, N_NAV):
            acc = 0.0
            for m in range(n):
                acc += T[i, m] * Phi[j, m]
            P[i, j] = acc
            P[j, i] = acc
        P[i, i] += q[i]
        for b in range(N_NAV, n):
            v = T[i, b] * Phi[b, b]
            P[i, b] = v
            P[b, i] = v
    for i in range(6):
        for j in range(6):
            P[i, j] += q_nav[i, j]
    for a in range(N_NAV, n):
        for b in range(a, n):
            v = Phi[a, a] * P[a, b] * Phi[b, b]
            P[a, b] = v
            P[b, a] = v
        P[a, a] += q[a]


def _scalar_update(
    P: FloatArray, x: FloatArray, h: FloatArray, r: float, z: float, ph: FloatArray
) -> None:  # pragma: no cover
    """Kalman update with one scalar measurement ``z = h·x + v``, ``var(v) = r``.

    ``x`` (n,) and ``P`` (n, n) are updated in place (symmetric form
    ``P ← P - (Ph)(Ph)^T / s``); ``ph`` (n,) is scratch.
    """
    n = P.shape[0]
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * h[j]
        ph[i] = acc
    s = r
    nu = z
    for i in range(n):
        s += h[i] * ph[i]
        nu -= h[i] * x[i]
    for i in range(n):
        k = ph[i] / s
        x[i] += k * nu
        for j in range(i, n):
            v = P[i, j] - k * ph[j]
            P[i, j] = v
            P[j, i] = v


def _feedback(
    s: FloatArray, x: FloatArray, qa: FloatArray, qb: FloatArray, C: FloatArray
) -> None:  # pragma: no cover
    """Correct the nominal state ``s`` with the error state ``x`` (``true ≈ s ⊖ x``).

    ``qa``, ``qb`` (4,) and ``C`` (3, 3) are scratch.
    """
    n = x.shape[0]
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
    # v ← Rot(φ) (v - δv'): the velocity turns with the attitude correction.
    quat_to_dcm(qa, C)
    u0 = s[I_VEL] - x[3]
    u1 = s[I_VEL + 1] - x[4]
    u2 = s[I_VEL + 2] - x[5]
    for i in range(3):
        s[I_VEL + i] = C[i, 0] * u0 + C[i, 1] * u1 + C[i, 2] * u2
        s[I_BG + i] += x[X_BG + i]
        s[I_BA + i] += x[X_BA + i]
        s[I_MG + i] += x[X_MG + i]
        s[I_MA + i] += x[X_MA + i]
        if n >= N_ERR_SCALE:
            s[I_SG + i] += x[X_SG + i]
            s[I_SA + i] += x[X_SA + i]
    ic = support_index(n)
    if ic >= 0:
        s[I_CV] += x[ic]
    s[I_LAT] = lat - x[6] / (r_m + h)
    s[I_LON] -= x[7] / ((r_n + h) * math.cos(lat))
    s[I_H] = h + x[8]


def _tilt_gravity_mean(P: FloatArray, s: FloatArray, dt: float) -> None:  # pragma: no cover
    """Remove the expected second-order tilt error of one interval from the velocity.

    ``v ← v - Δt E[-½ [φ×]² g]`` with ``φ ~ N(0, P[:3, :3])`` (module docstring):
    ``v_N += ½ g P_ND Δt``, ``v_E += ½ g P_ED Δt``, ``v_D -= ½ g (P_NN + P_EE) Δt``.
    ``P`` is the predicted covariance, ``s`` the mechanised state (changed in place).
    """
    hg = 0.5 * normal_gravity_m_s2(s[I_LAT], s[I_H]) * dt
    s[I_VEL] += hg * P[0, 2]
    s[I_VEL + 1] += hg * P[1, 2]
    s[I_VEL + 2] -= hg * (P[0, 0] + P[1, 1])


def _tilt_moments(P: FloatArray, g: float) -> tuple[float, float]:  # pragma: no cover
    """Mean ``½ g tr(P_h)`` and variance ``½ g² tr(P_h²)`` of ``c = ½ g |φ_h|²``.

    ``φ_h ~ N(0, P_h)``, ``P_h = P[:2, :2]`` the tilt covariance (North, East).
    """
    a = P[0, 0]
    b = P[0, 1]
    d = P[1, 1]
    return 0.5 * g * (a + d), 0.5 * g * g * (a * a + 2.0 * b * b + d * d)


def _support_transition(v1: float, v2: float) -> tuple[float, float]:  # pragma: no cover
    """``Φ_cc = min(1, v2/v1)`` and ``Q_cc = v2 - Φ_cc² v1`` of ``c`` between two epochs.

    ``v1``, ``v2`` are the variances (`tilt_moments`) of ``c`` at the two epochs, from
    the tilt covariance before each epoch's updates (module docstring).
    """
    phi = min(1.0, v2 / v1) if v1 > 0.0 else 1.0
    return phi, v2 - phi * phi * v1


def _propagate_support(P: FloatArray, s: FloatArray, ic: int, g: float) -> None:  # pragma: no cover
    """The vertical support ``c`` over an interval, after `propagate_cov` (module docstring).

    ``P`` is the predicted covariance, propagated with ``Φ_cc = 1`` and no noise on
    ``c``; ``s[I_CM]``, ``s[I_CVAR]`` hold the moments of ``c`` at the interval's start.
    With the moments ``m2``, ``v2`` of ``P`` (`tilt_moments`), ``c``'s row and column
    are scaled by ``Φ_cc`` and ``Q_cc`` is added (`support_transition`), in the order
    `propagate_cov` computes them with that ``Φ_cc`` and ``Q_cc`` (the smoother
    does, from the stored moments); the estimate becomes ``ĉ ← m2 + Φ_cc (ĉ - m1)``
    and ``m2``, ``v2`` are stored.
    """
    m2, v2 = tilt_moments(P, g)
    phi, qc = support_transition(s[I_CVAR], v2)
    n = P.shape[0]
    for j in range(n):
        if j != ic:
            v = P[ic, j] * phi
            P[ic, j] = v
            P[j, ic] = v
    P[ic, ic] = phi * P[ic, ic] * phi + qc
    s[I_CV] = m2 + phi * (s[I_CV] - s[I_CM])
    s[I_CM] = m2
    s[I_CVAR] = v2


def _remove_support(
    P: FloatArray, s: FloatArray, dt: float, horizontal: bool
) -> None:  # pragma: no cover
    """Remove the second-order tilt term of one interval from the velocity, with ``c``.

    ``v_D -= ĉ Δt`` and, when ``horizontal`` (the vehicle moves), the horizontal terms
    of `tilt_gravity_mean` (``c`` is its vertical term).
    """
    if horizontal:
        hg = 0.5 * normal_gravity_m_s2(s[I_LAT], s[I_H]) * dt
        s[I_VEL] += hg * P[0, 2]
        s[I_VEL + 1] += hg * P[1, 2]
    s[I_VEL + 2] -= s[I_CV] * dt


def _process_noise(
    params: FloatArray, s: FloatArray, dt: float, q: FloatArray, q_nav: FloatArray
) -> None:  # pragma: no cover
    """Discrete process noise of an interval: ``diag(q)`` (n,) and the 6×6 ``q_nav``.

    White gyro noise enters through ``G = [-C; [v×] C]`` and accelerometer noise through
    ``[0; C]``; with isotropic noise ``C`` drops out of ``G Q_c G^T``::

        q_nav = arw² Δt [[I, [v×]], [-[v×], -[v×]²]] + vrw² Δt [[0, 0], [0, I]]
    """
    n = q.shape[0]
    qa = params[P_QC_ATT] * dt
    qv = params[P_QC_VEL] * dt
    vn, ve, vd = s[I_VEL], s[I_VEL + 1], s[I_VEL + 2]
    # [v×]
    V = ((0.0, -vd, ve), (vd, 0.0, -vn), (-ve, vn, 0.0))
    vv = vn * vn + ve * ve + vd * vd
    vel = (vn, ve, vd)
    for i in range(3):
        for j in range(3):
            q_nav[i, j] = qa if i == j else 0.0
            q_nav[i, 3 + j] = qa * V[i][j]
            q_nav[3 + i, j] = -qa * V[i][j]
            # -[v×]² = |v|² I - v v^T
            q_nav[3 + i, 3 + j] = qa * ((vv if i == j else 0.0) - vel[i] * vel[j])
        q_nav[3 + i, 3 + i] += qv
    for i in range(n):
        q[i] = 0.0
    for i in range(3):
        q[X_MG + i] = params[P_QC_BG] * dt
        q[X_MA + i] = params[P_QC_BA] * dt


def _step_matrices(
    s: FloatArray,
    gyro: FloatArray,
    acc: FloatArray,
    dt: float,
    t_s: float,
    params: FloatArray,
    w_b: FloatArray,
    f_b: FloatArray,
    C: FloatArray,
    F: FloatArray,
    Phi: FloatArray,
    q: FloatArray,
    q_nav: FloatArray,
) -> None:  # pragma: no cover
    """``Φ`` and ``Q`` of the interval ending at an IMU sample (state at its start).

    ``t_s`` is the interval's start (s). Before ``params[P_FEJ_END]`` (the initial
    standstill) the accelerometer-error columns take the levelled attitude of
    ``params[P_FEJ_C:]`` instead of the state's (first-estimates Jacobian, module
    docstring). The vertical support ``δc``, when the state has it, drives the down
    velocity; its own transition and noise are left at 1 and 0 here
    (`propagate_support`).
    """
    corrected_imu(s, gyro, acc, w_b, f_b)
    system_matrix(s, w_b, f_b, params[P_TAU_G], params[P_TAU_A], C, F)
    if t_s < params[P_FEJ_END]:
        for i in range(3):
            for col in (X_BA + i, X_MA + i):
                for r in range(3):
                    F[3 + r, col] = params[P_FEJ_C + 3 * r + i]
    ic = support_index(F.shape[0])
    if ic >= 0:
        F[5, ic] = 1.0
    transition_from_system(F, dt, Phi)
    process_noise(params, s, dt, q, q_nav)


def _velocity_variance(P: FloatArray, s: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """Variances (3,) of the NED velocity error ``δv = δv' + [v×] φ`` from ``P``."""
    vn, ve, vd = s[I_VEL], s[I_VEL + 1], s[I_VEL + 2]
    V = ((0.0, -vd, ve), (vd, 0.0, -vn), (-ve, vn, 0.0))
    for i in range(3):
        acc = P[3 + i, 3 + i]
        for k in range(3):
            acc += 2.0 * V[i][k] * P[k, 3 + i]
            for m in range(3):
                acc += V[i][k] * P[k, m] * V[i][m]
        out[i] = acc


def _solution_std(P: FloatArray, s: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """The `N_OUT` standard deviations of the solution from the error covariance ``P``.

    Velocity: of ``δv = δv' + [v×] φ``; bias: of the total ``δb + δm`` of each axis.
    """
    n = P.shape[0]
    var = np.empty(3)
    velocity_variance(P, s, var)
    for i in range(3):
        out[i] = math.sqrt(max(P[i, i], 0.0))
        out[3 + i] = math.sqrt(max(var[i], 0.0))
        out[6 + i] = math.sqrt(max(P[6 + i, 6 + i], 0.0))
        bg = P[X_BG + i, X_BG + i] + P[X_MG + i, X_MG + i] + 2.0 * P[X_BG + i, X_MG + i]
        ba = P[X_BA + i, X_BA + i] + P[X_MA + i, X_MA + i] + 2.0 * P[X_BA + i, X_MA + i]
        out[9 + i] = math.sqrt(max(bg, 0.0))
        out[12 + i] = math.sqrt(max(ba, 0.0))
        if n >= N_ERR_SCALE:
            out[15 + i] = math.sqrt(max(P[X_SG + i, X_SG + i], 0.0))
            out[18 + i] = math.sqrt(max(P[X_SA + i, X_SA + i], 0.0))
        else:
            out[15 + i] = math.nan
            out[18 + i] = math.nan


corrected_imu = _jit(_corrected_imu)
system_matrix = _jit(_build_F)
transition_from_system = _jit(_phi_from_F)
propagate_cov = _jit(_propagate_cov)
scalar_update = _jit(_scalar_update)
feedback = _jit(_feedback)
process_noise = _jit(_process_noise)
step_matrices = _jit(_step_matrices)
velocity_variance = _jit(_velocity_variance)
solution_std = _jit(_solution_std)
tilt_gravity_mean = _jit(_tilt_gravity_mean)
tilt_moments = _jit(_tilt_moments)
support_transition = _jit(_support_transition)
propagate_support = _jit(_propagate_support)
remove_support = _jit(_remove_support)
