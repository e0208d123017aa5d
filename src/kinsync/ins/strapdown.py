"""Strapdown inertial mechanisation in the local NED frame (SPEC section 6).

The navigation state is geodetic latitude, longitude (rad) and ellipsoidal height (m)
on WGS84, the velocity over the Earth in NED (m/s) and the attitude body -> NED as a
scalar-first unit quaternion, plus the sensor error estimates that correct the IMU
samples: turn-on biases, bias instabilities and scale factors of the gyros and
accelerometers (the filter feeds them back; the free-inertial run keeps them at zero),
and the filter's estimate of the second-order vertical support of a levelled tilt
during an initial standstill (`kinsync.ins._ekf`; not used by the mechanisation here).
A corrected sample is ``ω = (ω_measured - b_g - m_g) / (1 + s_g)``, likewise ``f``.

One step from IMU epoch ``k-1`` to ``k`` (sample ``k`` holds the mean rate and specific
force over ``(t[k-1], t[k]]``, `ImuData`):

1. Increments ``dθ = ωΔt`` and ``dv = fΔt`` of the corrected sample.
2. Coning and sculling with the previous sample's increments (two-sample
   algorithms): ``φ = dθ + dθ_prev × dθ / 12`` and
   ``dv_b = dv + dθ × dv / 2 + (dθ_prev × dv + dv_prev × dθ) / 12`` (the second term is
   the rotation compensation). On the first step the previous increments are taken
   equal to the current ones, which makes both corrections vanish.
3. Velocity: ``v += (I - [ζ×]/2) C_b^n dv_b + (g - (2ω_ie + ω_en) × v) Δt`` with the
   navigation-frame rotation ``ζ = (ω_ie + ω_en) Δt`` (Earth rate plus transport rate),
   normal gravity ``g`` along +Down, all evaluated at the start of the interval.
4. Position: trapezoidal velocity, radii of curvature at the start of the interval,
   longitude rate at the mid-interval latitude.
5. Attitude: ``q_b^n(k) = q(-ζ) ⊗ q_b^n(k-1) ⊗ q(φ)``, renormalised.

On a static IMU on the rotating Earth the body increment ``φ`` and the frame rotation
``ζ`` cancel exactly and the velocity terms cancel to second order in ``ζ``.

References
----------
P. G. Savage, "Strapdown inertial navigation integration algorithm design, part 1:
attitude algorithms; part 2: velocity and position algorithms", J. Guidance, Control,
and Dynamics 21(1) and 21(2), 1998 (coning, sculling, rotation compensation).
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, section 5.4 (local-navigation-frame
mechanisation) and 5.5.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_quaternion, quaternion_to_euler_rpy
from kinsync.ins.earth import A_M, E2, OMEGA_IE_RAD_S, normal_gravity_m_s2
from kinsync.ins.measurements import ImuData
from kinsync.ins.solution import InitialState, NavSolution

__all__ = ["free_inertial"]

_jit = cached_njit()

# Layout of the navigation state vector used by the compiled loops.
I_LAT, I_LON, I_H = 0, 1, 2
I_VEL = 3  # 3..5  vN, vE, vD
I_Q = 6  # 6..9   q_body_to_ned (w, x, y, z)
I_BG = 10  # 10..12 gyro turn-on bias estimate (rad/s, body)
I_BA = 13  # 13..15 accelerometer turn-on bias estimate (m/s^2, body)
I_MG = 16  # 16..18 gyro bias instability estimate (rad/s, body)
I_MA = 19  # 19..21 accelerometer bias instability estimate (m/s^2, body)
I_SG = 22  # 22..24 gyro scale factor estimate (dimensionless)
I_SA = 25  # 25..27 accelerometer scale factor estimate (dimensionless)
I_CV = 28  # second-order vertical support of the tilt (m/s^2), `kinsync.ins._ekf`
I_CM = 29  # its prior mean at this epoch, before the epoch's updates (m/s^2)
I_CVAR = 30  # and its prior variance (m^2/s^4)
N_STATE = 31
N_PREV = 6  # previous sample's dθ (0..2) and dv (3..5), body frame


# ---------------------------------------------------------------------- compiled helpers
def _quat_mul(p: FloatArray, q: FloatArray, out: FloatArray) -> None:  # pragma: no cover
    """Hamilton product ``out = p ⊗ q`` (scalar-first); ``out`` may alias neither input."""
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    out[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    out[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    out[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]


def _rotvec_to_quat(vx: float, vy: float, vz: float, out: FloatArray) -> None:  # pragma: no cover
    """Unit quaternion of the rotation vector (vx, vy, vz) (rad)."""
    a2 = vx * vx + vy * vy + vz * vz
    if a2 < 1e-8:
        c = 1.0 - a2 * (1.0 / 8.0 - a2 / 384.0)
        s = 0.5 - a2 * (1.0 / 48.0 - a2 / 3840.0)
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        s = math.sin(0.5 * a) / a
    out[0] = c
    out[1] = s * vx
    out[2] = s * vy
    out[3] = s * vz


def _quat_to_dcm(q: FloatArray, C: FloatArray) -> None:  # pragma: no cover
    """Rotation matrix ``C_b^n`` of the unit quaternion ``q_b^n``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    C[0, 0] = w * w + x * x - y * y - z * z
    C[0, 1] = 2.0 * (x * y - w * z)
    C[0, 2] = 2.0 * (x * z + w * y)
    C[1, 0] = 2.0 * (x * y + w * z)
    C[1, 1] = w * w - x * x + y * y - z * z
    C[1, 2] = 2.0 * (y * z - w * x)
    C[2, 0] = 2.0 * (x * z - w * y)
    C[2, 1] = 2.0 * (y * z + w * x)
    C[2, 2] = w * w - x * x - y * y + z * z


def _mech_step(  # noqa: PLR0915 - one flat function is what numba compiles best
    s: FloatArray,
    prev: FloatArray,
    gyro: FloatArray,
    acc: FloatArray,
    dt: float,
    first: bool,
    coning: bool,
    qa: FloatArray,
    qb: FloatArray,
    C: FloatArray,
) -> None:  # pragma: no cover - compiled by numba; tested through free_inertial
    """Advance the state ``s`` in place by one IMU interval (see the module docstring).

    ``gyro``/``acc`` are the raw sample (rad/s, m/s^2, body), corrected with the sensor
    error estimates in ``s``. ``prev`` holds the previous corrected increments and is
    updated. ``qa``, ``qb`` (4,) and ``C`` (3, 3) are scratch arrays.
    """
    tx = (gyro[0] - s[I_BG] - s[I_MG]) / (1.0 + s[I_SG]) * dt
    ty = (gyro[1] - s[I_BG + 1] - s[I_MG + 1]) / (1.0 + s[I_SG + 1]) * dt
    tz = (gyro[2] - s[I_BG + 2] - s[I_MG + 2]) / (1.0 + s[I_SG + 2]) * dt
    ux = (acc[0] - s[I_BA] - s[I_MA]) / (1.0 + s[I_SA]) * dt
    uy = (acc[1] - s[I_BA + 1] - s[I_MA + 1]) / (1.0 + s[I_SA + 1]) * dt
    uz = (acc[2] - s[I_BA + 2] - s[I_MA + 2]) / (1.0 + s[I_SA + 2]) * dt
    if first or not coning:
        px, py, pz, pvx, pvy, pvz = tx, ty, tz, ux, uy, uz
    else:
        px, py, pz = prev[0], prev[1], prev[2]
        pvx, pvy, pvz = prev[3], prev[4], prev[5]
    # Coning (two-sample) and sculling + rotation compensation.
    phx = tx + (py * tz - pz * ty) / 12.0
    phy = ty + (pz * tx - px * tz) / 12.0
    phz = tz + (px * ty - py * tx) / 12.0
    if coning:
        dvx = ux + 0.5 * (ty * uz - tz * uy) + ((py * uz - pz * uy) + (pvy * tz - pvz * ty)) / 12.0
        dvy = uy + 0.5 * (tz * ux - tx * uz) + ((pz * ux - px * uz) + (pvz * tx - pvx * tz)) / 12.0
        dvz = uz + 0.5 * (tx * uy - ty * ux) + ((px * uy - py * ux) + (pvx * ty - pvy * tx)) / 12.0
    else:
        dvx, dvy, dvz = ux, uy, uz
    prev[0], prev[1], prev[2] = tx, ty, tz
    prev[3], prev[4], prev[5] = ux, uy, uz

    lat = s[I_LAT]
    h = s[I_H]
    vn, ve, vd = s[I_VEL], s[I_VEL + 1], s[I_VEL + 2]
    sl = math.sin(lat)
    cl = math.cos(lat)
    den = 1.0 - E2 * sl * sl
    r_n = A_M / math.sqrt(den)
    r_m = A_M * (1.0 - E2) / (den * math.sqrt(den))
    rmh = r_m + h
    rnh = r_n + h
    # Earth rate and transport rate (NED).
    wie_n = OMEGA_IE_RAD_S * cl
    wie_d = -OMEGA_IE_RAD_S * sl
    wen_n = ve / rnh
    wen_e = -vn / rmh
    wen_d = -ve * sl / (cl * rnh)
    zx = (wie_n + wen_n) * dt
    zy = wen_e * dt
    zz = (wie_d + wen_d) * dt
    g = normal_gravity_m_s2(lat, h)

    # Velocity: C_b^n dv_b, rotated to mid-interval, plus gravity and Coriolis.
    quat_to_dcm(s[I_Q : I_Q + 4], C)
    fx = C[0, 0] * dvx + C[0, 1] * dvy + C[0, 2] * dvz
    fy = C[1, 0] * dvx + C[1, 1] * dvy + C[1, 2] * dvz
    fz = C[2, 0] * dvx + C[2, 1] * dvy + C[2, 2] * dvz
    gx = fx - 0.5 * (zy * fz - zz * fy)
    gy = fy - 0.5 * (zz * fx - zx * fz)
    gz = fz - 0.5 * (zx * fy - zy * fx)
    cx = 2.0 * wie_n + wen_n
    cy = wen_e
    cz = 2.0 * wie_d + wen_d
    vn_new = vn + gx - (cy * vd - cz * ve) * dt
    ve_new = ve + gy - (cz * vn - cx * vd) * dt
    vd_new = vd + gz - (cx * ve - cy * vn) * dt + g * dt

    # Position (trapezoidal velocity).
    h_new = h - 0.5 * (vd + vd_new) * dt
    h_mid = 0.5 * (h + h_new)
    lat_new = lat + 0.5 * (vn + vn_new) * dt / (r_m + h_mid)
    lat_mid = 0.5 * (lat + lat_new)
    s[I_LON] += 0.5 * (ve + ve_new) * dt / ((r_n + h_mid) * math.cos(lat_mid))
    s[I_LAT] = lat_new
    s[I_H] = h_new
    s[I_VEL] = vn_new
    s[I_VEL + 1] = ve_new
    s[I_VEL + 2] = vd_new

    # Attitude: q(-ζ) ⊗ q ⊗ q(φ).
    rotvec_to_quat(phx, phy, phz, qa)
    quat_mul(s[I_Q : I_Q + 4], qa, qb)
    rotvec_to_quat(-zx, -zy, -zz, qa)
    quat_mul(qa, qb, s[I_Q : I_Q + 4])
    nq = math.sqrt(s[I_Q] ** 2 + s[I_Q + 1] ** 2 + s[I_Q + 2] ** 2 + s[I_Q + 3] ** 2)
    for i in range(4):
        s[I_Q + i] /= nq


quat_mul = _jit(_quat_mul)
rotvec_to_quat = _jit(_rotvec_to_quat)
quat_to_dcm = _jit(_quat_to_dcm)
mech_step = _jit(_mech_step)


def _free_inertial_loop(
    k0: int,
    t_s: FloatArray,
    gyro: FloatArray,
    acc: FloatArray,
    state: FloatArray,
    coning: bool,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled by numba; tested through free_inertial
    """Mechanise epochs ``k0+1 .. n-1`` from ``state`` (the state at ``t_s[k0]``)."""
    n = t_s.shape[0]
    prev = np.zeros(N_PREV)
    qa = np.empty(4)
    qb = np.empty(4)
    C = np.empty((3, 3))
    out[k0, :] = state
    for k in range(k0 + 1, n):
        mech_step(state, prev, gyro[k], acc[k], t_s[k] - t_s[k - 1], k == k0 + 1, coning, qa, qb, C)
        out[k, :] = state


_free_inertial_kernel = cast(Callable[..., None], _jit(_free_inertial_loop))


# ---------------------------------------------------------------------- Python side
def start_epoch(imu: ImuData, init: InitialState) -> int:
    """Index of the IMU epoch the initial state belongs to.

    Raises
    ------
    InputError
        The initial time is not (within 1 ms) an IMU sample time, or the IMU has no
        sample after it.
    """
    t0 = float(init.t_s)
    if not math.isfinite(t0):
        msg = f"initial state: time must be finite, got {init.t_s!r}"
        raise InputError(msg)
    k0 = int(np.clip(np.searchsorted(imu.t_s, t0), 0, len(imu) - 1))
    if k0 > 0 and abs(imu.t_s[k0 - 1] - t0) < abs(imu.t_s[k0] - t0):
        k0 -= 1
    if abs(imu.t_s[k0] - t0) > 1e-3:
        msg = (
            f"initial state at t = {t0:.6f} s is not an IMU sample time (nearest "
            f"{imu.t_s[k0]:.6f} s; IMU spans {imu.t_s[0]:.6f} .. {imu.t_s[-1]:.6f} s): "
            "give the initial state at one of the IMU epochs"
        )
        raise InputError(msg)
    if k0 >= len(imu) - 1:
        msg = (
            f"initial state at t = {t0:.6f} s is the last IMU sample: nothing to mechanise; "
            "start the solution earlier"
        )
        raise InputError(msg)
    return k0


def check_imu_gaps(imu: ImuData, k0: int, max_gap_s: float) -> None:
    """Raise `InputError` naming the first IMU gap longer than ``max_gap_s`` after ``k0``."""
    dt = np.diff(imu.t_s[k0:])
    bad = np.flatnonzero(dt > max_gap_s)
    if bad.size:
        i = k0 + int(bad[0])
        msg = (
            f"IMU gap of {dt[bad[0]]:.6f} s between t = {imu.t_s[i]:.6f} s and "
            f"{imu.t_s[i + 1]:.6f} s (row {i + 1}) exceeds max_imu_gap_s = {max_gap_s} s; "
            "split the data at the gap or raise max_imu_gap_s"
        )
        raise InputError(msg)


def initial_state_vector(init: InitialState) -> FloatArray:
    """The compiled loops' state vector (31,), `N_STATE`, of an `InitialState`."""
    vals = [
        init.lat_deg, init.lon_deg, init.h_m, *init.vel_ned_m_s, *init.rpy_rad,
        *init.gyro_bias_rad_s, *init.acc_bias_m_s2,
    ]  # fmt: skip
    try:
        ok = len(vals) == 15 and all(math.isfinite(float(v)) for v in vals)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        msg = (
            "initial state: lat_deg, lon_deg, h_m, vel_ned_m_s (3), rpy_rad (3), "
            f"gyro_bias_rad_s (3) and acc_bias_m_s2 (3) must be finite numbers, got {vals!r}"
        )
        raise InputError(msg)
    if abs(init.lat_deg) >= 90.0:
        msg = f"initial state: latitude {init.lat_deg} deg is at or beyond a pole"
        raise InputError(msg)
    s = np.zeros(N_STATE)
    s[I_LAT] = math.radians(init.lat_deg)
    s[I_LON] = math.radians(init.lon_deg)
    s[I_H] = float(init.h_m)
    s[I_VEL : I_VEL + 3] = init.vel_ned_m_s
    s[I_Q : I_Q + 4] = euler_rpy_to_quaternion(*init.rpy_rad)
    s[I_BG : I_BG + 3] = init.gyro_bias_rad_s
    s[I_BA : I_BA + 3] = init.acc_bias_m_s2
    return s


def nav_solution_from_states(
    t_s: FloatArray,
    states: FloatArray,
    std: FloatArray | None,
    *,
    smoothed: bool = False,
    n_gnss_used: int = 0,
    n_gnss_rejected: int = 0,
) -> NavSolution:
    """Build a `NavSolution` from compiled-loop states (n, 31) and 1σ (n, 21) or None.

    ``std`` has the layout of `kinsync.ins._ekf.solution_std`: attitude, velocity,
    position, total gyro and accelerometer bias, scale factors (NaN if not modelled).
    The biases reported are the totals, turn-on plus instability estimates.
    """
    n = t_s.size
    q = states[:, I_Q : I_Q + 4]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    if std is None:
        std = np.full((n, 21), np.nan)
    scales = not np.all(np.isnan(std[:, 15:21]))
    lon = np.degrees(states[:, I_LON])
    lon = (lon + 180.0) % 360.0 - 180.0
    return NavSolution(
        t_s=np.array(t_s, dtype=np.float64),
        lat_deg=np.degrees(states[:, I_LAT]),
        lon_deg=lon,
        h_m=states[:, I_H].copy(),
        vel_ned_m_s=states[:, I_VEL : I_VEL + 3].copy(),
        rpy_rad=quaternion_to_euler_rpy(q),
        std_pos_ned_m=std[:, 6:9].copy(),
        std_vel_ned_m_s=std[:, 3:6].copy(),
        std_att_rad=std[:, 0:3].copy(),
        gyro_bias_rad_s=states[:, I_BG : I_BG + 3] + states[:, I_MG : I_MG + 3],
        acc_bias_m_s2=states[:, I_BA : I_BA + 3] + states[:, I_MA : I_MA + 3],
        std_gyro_bias_rad_s=std[:, 9:12].copy(),
        std_acc_bias_m_s2=std[:, 12:15].copy(),
        gyro_scale_ppm=states[:, I_SG : I_SG + 3] * 1e6 if scales else None,
        acc_scale_ppm=states[:, I_SA : I_SA + 3] * 1e6 if scales else None,
        std_gyro_scale_ppm=std[:, 15:18] * 1e6 if scales else None,
        std_acc_scale_ppm=std[:, 18:21] * 1e6 if scales else None,
        smoothed=smoothed,
        n_gnss_used=n_gnss_used,
        n_gnss_rejected=n_gnss_rejected,
    )


def mechanise_states(imu: ImuData, init: InitialState, *, coning: bool = True) -> FloatArray:
    """Raw compiled-loop states (n - k0, 31) of the free-inertial run from ``init``."""
    k0 = start_epoch(imu, init)
    state = initial_state_vector(init)
    out = np.empty((len(imu), N_STATE))
    _free_inertial_kernel(
        k0, imu.t_s, imu.gyro_body_rad_s, imu.acc_body_m_s2, state, bool(coning), out
    )
    return out[k0:]


def free_inertial(imu: ImuData, init: InitialState) -> NavSolution:
    """Pure strapdown mechanisation (no aiding) from an initial state.

    Parameters
    ----------
    imu : ImuData
        IMU samples (body X forward, Y right, Z down; rad/s and m/s^2).
    init : InitialState
        State of the IMU reference point at one of the IMU sample times.

    Returns
    -------
    NavSolution
        One row per IMU epoch from ``init.t_s`` to the last sample; standard
        deviations NaN, bias estimates zero, ``smoothed`` False.

    Raises
    ------
    InputError
        The initial time is not an IMU epoch, or the initial state is not finite.

    References
    ----------
    Savage 1998; Groves 2013, section 5.4 (see the module docstring).
    """
    k0 = start_epoch(imu, init)
    states = mechanise_states(imu, init)
    return nav_solution_from_states(imu.t_s[k0:], states, None)
