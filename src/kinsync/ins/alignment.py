"""Initial state from a static start: levelling, gyro drift, GNSS course-over-ground heading.

`align_static_gnss_heading` gives the `InitialState` that `kinsync.ins.filter.run_ins`
starts from when no reference state is known: the vehicle stands still for the first
seconds of the record (tested against the ``STATIC_*`` limits), the mean specific
force levels the IMU, the mean gyro output is the drift estimate, and the heading is
the GNSS course over ground once the vehicle drives off (MEMS gyros are far too noisy
for gyrocompassing).

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, ch. 5 (initialisation and alignment).
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import finite_vector
from kinsync.errors import InputError, ObservabilityError
from kinsync.frames import euler_rpy_to_matrix, mean_longitude_deg
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.file_rows import FileRows
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState

__all__ = [
    "GYRO_MEAN_STD_FLOOR_RAD_S",
    "HEADING_MIN_DISTANCE_M",
    "HEADING_MIN_SPEED_M_S",
    "HEADING_WINDOW_S",
    "LEVELLING_STD_FLOOR_RAD",
    "STANDSTILL_ACC_CHANGE_M_S2",
    "STANDSTILL_GYRO_CHANGE_RAD_S",
    "STANDSTILL_WINDOW_S",
    "STATIC_ACC_STD_M_S2",
    "STATIC_GNSS_SPEED_M_S",
    "STATIC_GRAVITY_TOL_M_S2",
    "STATIC_GYRO_STD_RAD_S",
    "align_static_gnss_heading",
    "standstill_end_s",
]

STATIC_ACC_STD_M_S2 = 0.3
"""Largest accelerometer standard deviation (per axis) accepted as "static" (m/s^2)."""
STATIC_GYRO_STD_RAD_S = 0.02
"""Largest gyro standard deviation (per axis) accepted as "static" (rad/s)."""
STATIC_GRAVITY_TOL_M_S2 = 0.5
"""Largest difference between the mean specific-force magnitude and normal gravity."""
STATIC_GNSS_SPEED_M_S = 0.5
"""Largest GNSS horizontal speed accepted during the static period (m/s)."""
HEADING_MIN_SPEED_M_S = 2.0
"""GNSS horizontal speed from which the course over ground is taken as heading (m/s)."""
HEADING_MIN_DISTANCE_M = 10.0
"""Without GNSS velocities: displacement from the static position that gives the heading."""
HEADING_WINDOW_S = 5.0
"""Course-over-ground epochs used for the heading: this long after the first one (s)."""
LEVELLING_STD_FLOOR_RAD = 1e-5
"""Smallest levelling noise σ reported (rad, 2 arcsec): keeps the tilt covariance
positive definite when the static samples are quantised to one value."""
GYRO_MEAN_STD_FLOOR_RAD_S = 1e-8
"""Smallest σ reported for the static mean gyro rate (rad/s, 0.002 deg/h), likewise."""
STANDSTILL_WINDOW_S = 1.0
"""Windows in which the standstill after the static period is followed (s)."""
STANDSTILL_ACC_CHANGE_M_S2 = 0.1
"""The standstill ends with a window whose mean specific force differs from the static
mean by more than this (m/s^2): 0.1 m/s^2 for a second is 0.1 m/s of speed."""
STANDSTILL_GYRO_CHANGE_RAD_S = math.radians(0.5)
"""... or whose mean angular rate differs from the static mean by more than this."""


def standstill_end_s(imu: ImuData, gnss: GnssData, k_end: int) -> float:
    """When the vehicle, at rest up to IMU epoch ``k_end``, first moves (s).

    The start of the first `STANDSTILL_WINDOW_S` window after ``k_end`` whose mean
    specific force or angular rate departs from the static mean (by
    `STANDSTILL_ACC_CHANGE_M_S2`, `STANDSTILL_GYRO_CHANGE_RAD_S`), or the first GNSS
    epoch after ``k_end`` faster than `STATIC_GNSS_SPEED_M_S`, whichever comes first;
    the end of the record if neither does.

    Parameters
    ----------
    imu : ImuData
        IMU samples, static up to ``k_end``.
    gnss : GnssData
        GNSS fixes (their velocities are used when present).
    k_end : int
        Last IMU epoch of the static period.

    Returns
    -------
    float
        Time (s), at least ``imu.t_s[k_end]``.
    """
    t = imu.t_s
    f0 = imu.acc_body_m_s2[: k_end + 1].mean(axis=0)
    w0 = imu.gyro_body_rad_s[: k_end + 1].mean(axis=0)
    end = float(t[-1])
    edges = np.searchsorted(t, np.arange(float(t[k_end]), end, STANDSTILL_WINDOW_S))
    edges = np.unique(np.append(edges[edges > k_end], len(t)))
    starts = np.concatenate([[k_end + 1], edges[:-1]])
    keep = edges > starts
    starts, stops = starts[keep], edges[keep]
    if starts.size:
        acc = np.add.reduceat(imu.acc_body_m_s2, starts, axis=0)[: starts.size]
        gyro = np.add.reduceat(imu.gyro_body_rad_s, starts, axis=0)[: starts.size]
        count = (stops - starts)[:, None]
        moved = (np.linalg.norm(acc / count - f0, axis=1) > STANDSTILL_ACC_CHANGE_M_S2) | (
            np.linalg.norm(gyro / count - w0, axis=1) > STANDSTILL_GYRO_CHANGE_RAD_S
        )
        if moved.any():
            end = float(t[starts[int(np.argmax(moved))]])
    if gnss.vel_ned_m_s is not None:
        after = gnss.t_s > t[k_end]
        fast = np.hypot(gnss.vel_ned_m_s[:, 0], gnss.vel_ned_m_s[:, 1]) > STATIC_GNSS_SPEED_M_S
        hits = np.flatnonzero(after & fast)
        if hits.size:
            end = min(end, float(gnss.t_s[hits[0]]))
    return max(end, float(t[k_end]))


_GIVE_INITIAL_STATE = "give the initial state (--init-from; an InitialState in Python)"
"""The way round a failed static alignment, as the command line and the API name it."""


def _vector_arg(value: object, name: str) -> FloatArray:
    """``value`` as 3 finite float64 numbers, or `InputError` naming ``name``."""
    return finite_vector(value, 3, f"align_static_gnss_heading: {name}", " (x, y, z, body frame)")


def _static_window(imu: ImuData, static_s: float) -> int:
    if not (isinstance(static_s, int | float) and math.isfinite(static_s) and static_s > 0):
        msg = f"align_static_gnss_heading: static_s must be a positive number, got {static_s!r}"
        raise InputError(msg)
    t0 = float(imu.t_s[0])
    if imu.t_s[-1] < t0 + static_s:
        msg = (
            f"no static start: the IMU record ({imu.t_s[-1] - t0:.3f} s) is shorter than the "
            f"static period of {static_s} s (--static-s)"
        )
        raise ObservabilityError(msg)
    k_end = int(np.searchsorted(imu.t_s, t0 + static_s, side="right")) - 1
    if k_end < 10:
        msg = (
            f"no static start: only {k_end + 1} IMU samples in the first {static_s} s; "
            "a longer static period (--static-s) is needed for levelling"
        )
        raise ObservabilityError(msg)
    return k_end


_LEAP_SECONDS = range(10, 19)
"""Whole seconds GPS time has run ahead of UTC (10 s in 1995 to 18 s since 2017)."""


def _first_fix_text(gnss: GnssData, t0_s: float, names: FileRows | None) -> str:
    """Where the GNSS fixes are, when none falls in the static period, and why, maybe."""
    rows_of = names or FileRows()
    after = int(np.searchsorted(gnss.t_s, t0_s))
    if after >= len(gnss):
        return ""
    t1 = float(gnss.t_s[after])
    if after > 0:
        before = float(gnss.t_s[after - 1])
        return (
            f". The fixes around it are at t_s {before:.3f} ({rows_of.where(after - 1)}) and "
            f"t_s {t1:.3f} ({rows_of.where(after)}): a GNSS outage of {t1 - before:.3f} s"
        )
    late_s = t1 - t0_s
    whole = round(late_s)
    cause = (
        f"{whole} s is what GPS time runs ahead of UTC (leap seconds; 18 s since 2017): is "
        "one file in UTC and the other in GPS time?"
        if whole in _LEAP_SECONDS and abs(late_s - whole) < 0.5
        else "are they on another time scale, or offset?"
    )
    return (
        f". The first fix is at t_s {t1:.3f} ({rows_of.where(after)}), {late_s:.3f} s after "
        f"the first IMU sample: are the GNSS times late against the IMU's? {cause} Put both "
        "on the same time scale"
    )


def _check_static(
    imu: ImuData, gnss: GnssData, k_end: int, static_s: float, lat_rad: float, h_m: float
) -> None:
    acc = imu.acc_body_m_s2[: k_end + 1]
    gyro = imu.gyro_body_rad_s[: k_end + 1]
    acc_std = float(acc.std(axis=0).max())
    gyro_std = float(gyro.std(axis=0).max())
    g = float(normal_gravity_m_s2(lat_rad, h_m))
    g_err = abs(float(np.linalg.norm(acc.mean(axis=0))) - g)
    t0 = imu.t_s[0]
    speed = 0.0
    if gnss.vel_ned_m_s is not None:
        sel = (gnss.t_s >= t0) & (gnss.t_s <= imu.t_s[k_end])
        if sel.any():
            speed = float(np.hypot(gnss.vel_ned_m_s[sel, 0], gnss.vel_ned_m_s[sel, 1]).max())
    if (
        acc_std > STATIC_ACC_STD_M_S2
        or gyro_std > STATIC_GYRO_STD_RAD_S
        or g_err > STATIC_GRAVITY_TOL_M_S2
        or speed > STATIC_GNSS_SPEED_M_S
    ):
        msg = (
            f"no static start: over the first {static_s} s (from t = {t0:.3f} s) the "
            f"accelerometer std is {acc_std:.3f} m/s^2 (limit {STATIC_ACC_STD_M_S2}), the gyro "
            f"std {gyro_std:.4f} rad/s (limit {STATIC_GYRO_STD_RAD_S}), |mean specific force| - "
            f"gravity {g_err:.3f} m/s^2 (limit {STATIC_GRAVITY_TOL_M_S2}), the GNSS speed up to "
            f"{speed:.2f} m/s (limit {STATIC_GNSS_SPEED_M_S}); start the record with the vehicle "
            f"at rest, shorten the static period (--static-s), or {_GIVE_INITIAL_STATE}"
        )
        at_rest = (
            acc_std <= STATIC_ACC_STD_M_S2
            and g_err <= STATIC_GRAVITY_TOL_M_S2
            and speed <= STATIC_GNSS_SPEED_M_S
        )
        if at_rest and gyro_std * math.pi / 180.0 <= STATIC_GYRO_STD_RAD_S:
            msg = (
                f"over the first {static_s} s (from t = {t0:.3f} s) the accelerometers"
                f"{' and the GNSS' if gnss.vel_ned_m_s is not None else ''} show a vehicle at "
                f"rest, but the gyro std is {gyro_std:.4f} rad/s, "
                f"{gyro_std / STATIC_GYRO_STD_RAD_S:.3g} times a standstill's limit "
                f"{STATIC_GYRO_STD_RAD_S}: are the rates in deg/s? Convert them to rad/s "
                "(multiply by pi/180)"
            )
        raise ObservabilityError(msg)


def _yaw_turned(
    imu: ImuData, k_end: int, gyro_bias: FloatArray, roll: float, pitch: float
) -> FloatArray:
    """Yaw turned since the end of the static period at each IMU epoch (rad, n,)."""
    w = imu.gyro_body_rad_s - gyro_bias
    rate = (w[:, 1] * math.sin(roll) + w[:, 2] * math.cos(roll)) / math.cos(pitch)
    inc = np.zeros(len(imu))
    inc[1:] = rate[1:] * np.diff(imu.t_s)
    inc[: k_end + 1] = 0.0
    out: FloatArray = np.cumsum(inc)
    return out


def _heading(
    imu: ImuData,
    gnss: GnssData,
    k_end: int,
    lat0: float,
    lon0: float,
    roll: float,
    pitch: float,
    gyro_bias: FloatArray,
    arm_body_m: FloatArray,
) -> float:
    """Heading at the end of the static period from GNSS course over ground (rad)."""
    t_end = float(imu.t_s[k_end])
    after = np.flatnonzero((gnss.t_s > t_end) & (gnss.t_s <= imu.t_s[-1]))
    turned = _yaw_turned(imu, k_end, gyro_bias, roll, pitch)
    k_of = np.clip(np.searchsorted(imu.t_s, gnss.t_s[after]), 0, len(imu) - 1)
    if gnss.vel_ned_m_s is not None:
        vel = gnss.vel_ned_m_s[after]
        speed = np.hypot(vel[:, 0], vel[:, 1])
        moving = np.flatnonzero(speed >= HEADING_MIN_SPEED_M_S)
        if moving.size == 0:
            msg = (
                f"no motion to get heading from: the GNSS horizontal speed never reaches "
                f"{HEADING_MIN_SPEED_M_S} m/s after the static period (t > {t_end:.3f} s); "
                f"drive off after the static start, or {_GIVE_INITIAL_STATE}"
            )
            raise ObservabilityError(msg)
        t_first = gnss.t_s[after[moving[0]]]
        use = moving[gnss.t_s[after[moving]] <= t_first + HEADING_WINDOW_S]
        yaw = 0.0
        for _ in range(2):  # second pass: lever-arm velocity with the first heading
            yaws = np.empty(use.size)
            for i, u in enumerate(use):
                k = int(k_of[u])
                R = euler_rpy_to_matrix(roll, pitch, yaw + turned[k])
                w = imu.gyro_body_rad_s[k] - gyro_bias
                v_imu = vel[u] - R @ np.cross(w, arm_body_m)
                yaws[i] = math.atan2(v_imu[1], v_imu[0]) - turned[k]
            wts = speed[use] ** 2
            yaw = math.atan2(float(np.sum(wts * np.sin(yaws))), float(np.sum(wts * np.cos(yaws))))
        return yaw
    r_m, r_n = radii_m(lat0)
    dn = np.radians(gnss.lat_deg[after] - math.degrees(lat0)) * r_m
    dlon_deg = gnss.lon_deg[after] - math.degrees(lon0)
    dlon_deg = np.where(np.abs(dlon_deg) > 180.0, (dlon_deg + 180.0) % 360.0 - 180.0, dlon_deg)
    de = np.radians(dlon_deg) * r_n * math.cos(lat0)
    sig = np.nan_to_num(np.hypot(gnss.std_pos_ned_m[after, 0], gnss.std_pos_ned_m[after, 1]))
    far = np.flatnonzero(np.hypot(dn, de) >= np.maximum(HEADING_MIN_DISTANCE_M, 10.0 * sig))
    if far.size == 0:
        msg = (
            "no motion to get heading from: no GNSS fix after the static period lies "
            f"{HEADING_MIN_DISTANCE_M} m (or 10 sigma) from the static position, and the file "
            "has no velocities; drive off after the static start, or " + _GIVE_INITIAL_STATE
        )
        raise ObservabilityError(msg)
    i = int(far[0])
    # bearing of the displacement, taken as the mean heading since the static end
    return math.atan2(float(de[i]), float(dn[i])) - 0.5 * float(turned[k_of[i]])


def align_static_gnss_heading(
    imu: ImuData,
    gnss: GnssData,
    *,
    static_s: float = 5.0,
    antenna_lever_arm_body_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    gyro_bias_rad_s: tuple[float, float, float] | None = None,
    acc_bias_m_s2: tuple[float, float, float] | None = None,
    gnss_source: str = "GNSS data",
    gnss_rows: FileRows | None = None,
) -> InitialState:
    """Initial state by static levelling and GNSS course-over-ground heading.

    1. The first ``static_s`` seconds of IMU data must be static (accelerometer and
       gyro standard deviations, specific-force magnitude against normal gravity, and
       GNSS speed when available, within the module's ``STATIC_*`` limits).
    2. Levelling: ``roll = atan2(-f_y, -f_z)``, ``pitch = atan2(f_x, sqrt(f_y² + f_z²))``
       from the mean specific force, less the known accelerometer bias when one is
       given (the remaining bias enters as tilt: 1 mg ≈ 0.06°; the returned state says
       so with ``levelling_std_rad``; the filter starts roll and pitch as the
       horizontal accelerometer error over g, correlated with the accelerometer states,
       plus the levelling noise: `kinsync.ins.filter.initial_covariance`, and carries
       the second-order vertical support of that tilt as a state:
       `kinsync.ins.standstill`).
    3. The mean gyro output is the initial gyro drift estimate (the Earth rate,
       projected with the final attitude, is removed), unless a known (laboratory)
       gyro bias is given. MEMS gyros are far too noisy for gyrocompassing, so the
       heading comes from GNSS:
    4. Heading: the course over ground (antenna velocity minus the lever-arm term
       ``C (ω × l)``) of the GNSS epochs with a horizontal speed of at least
       `HEADING_MIN_SPEED_M_S` during `HEADING_WINDOW_S` after the first one, each
       carried back to the end of the static period by integrating the bias-corrected
       yaw rate ``(ω_y sin φ + ω_z cos φ) / cos θ``, averaged with weights ``speed²``
       (no side slip assumed). Without GNSS velocities: the bearing of the first fix
       `HEADING_MIN_DISTANCE_M` (or 10σ) away from the static position, corrected by
       half the yaw turned until then.
    5. Position: mean GNSS fix of the static period, moved from the antenna to the
       IMU with the lever arm; velocity zero.

    The vehicle stands still throughout the static period, so the state holds from its
    first IMU epoch: the filter starts there and its solution covers every IMU epoch.

    Parameters
    ----------
    imu : ImuData
        IMU samples starting with the static period.
    gnss : GnssData
        GNSS fixes (velocities strongly preferred).
    static_s : float
        Length of the static period at the start of ``imu`` (s).
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna lever arm, body frame (m).
    gyro_bias_rad_s, acc_bias_m_s2 : (float, float, float), optional
        Known turn-on biases (body frame, e.g. a laboratory calibration), removed
        before levelling and heading; returned in the state as its bias estimates.
    gnss_source : str
        Name of the GNSS input in messages (its file path).
    gnss_rows : FileRows, optional
        The file rows and lines of ``gnss``'s rows, for messages.

    Returns
    -------
    InitialState
        At the first IMU epoch, with the gyro drift estimate (or the known biases),
        ``levelling_std_rad`` and ``static_until_s`` (`standstill_end_s`) set.

    Raises
    ------
    ObservabilityError
        No static start, no GNSS fix during it, or no motion to take the heading from.
    InputError
        ``static_s`` is not a positive number; a lever arm or bias that is not 3 finite
        numbers.
    """
    arm = _vector_arg(antenna_lever_arm_body_m, "antenna_lever_arm_body_m")
    acc_bias = np.zeros(3) if acc_bias_m_s2 is None else _vector_arg(acc_bias_m_s2, "acc_bias_m_s2")
    known_gyro = None
    if gyro_bias_rad_s is not None:
        known_gyro = _vector_arg(gyro_bias_rad_s, "gyro_bias_rad_s")
    k_end = _static_window(imu, static_s)
    t0 = float(imu.t_s[0])
    t_end = float(imu.t_s[k_end])
    in_static = (gnss.t_s >= t0) & (gnss.t_s <= t_end)
    if not in_static.any():
        where = _first_fix_text(gnss, t0, gnss_rows)
        msg = (
            f"{gnss_source}: no GNSS fix during the static period {t0:.3f} .. {t_end:.3f} s "
            f"(the first {static_s:g} s of the IMU record), so the initial position is unknown"
            f"{where}; {'or ' if where else ''}lengthen the static period (--static-s) or "
            + _GIVE_INITIAL_STATE
        )
        raise ObservabilityError(msg)
    lat0 = math.radians(float(gnss.lat_deg[in_static].mean()))
    lon0 = math.radians(mean_longitude_deg(gnss.lon_deg[in_static]))  # 180 deg: not 0
    h0 = float(gnss.h_m[in_static].mean())
    _check_static(imu, gnss, k_end, static_s, lat0, h0)
    acc = imu.acc_body_m_s2[: k_end + 1]
    f = acc.mean(axis=0) - acc_bias
    roll = math.atan2(-f[1], -f[2])
    pitch = math.atan2(f[0], math.hypot(f[1], f[2]))
    g = float(normal_gravity_m_s2(lat0, h0))
    noise = float(acc[:, :2].std(axis=0).max()) / math.sqrt(acc.shape[0]) / g
    gyro = imu.gyro_body_rad_s[: k_end + 1]
    gyro_mean = gyro.mean(axis=0)
    gyro_noise = np.maximum(gyro.std(axis=0) / math.sqrt(gyro.shape[0]), GYRO_MEAN_STD_FLOOR_RAD_S)
    drift = gyro_mean if known_gyro is None else known_gyro
    yaw = _heading(imu, gnss, k_end, lat0, lon0, roll, pitch, drift, arm)
    yaw = (yaw + math.pi) % (2.0 * math.pi) - math.pi
    R = euler_rpy_to_matrix(roll, pitch, yaw)
    w_ie = np.array([OMEGA_IE_RAD_S * math.cos(lat0), 0.0, -OMEGA_IE_RAD_S * math.sin(lat0)])
    gyro_bias = gyro_mean - R.T @ w_ie if known_gyro is None else known_gyro
    arm_ned = R @ arm
    r_m, r_n = radii_m(lat0)
    lat = lat0 - arm_ned[0] / (r_m + h0)
    lon = lon0 - arm_ned[1] / ((r_n + h0) * math.cos(lat0))
    return InitialState(
        t_s=t0,
        lat_deg=math.degrees(lat),
        lon_deg=math.degrees(lon),
        h_m=float(h0 + arm_ned[2]),
        vel_ned_m_s=(0.0, 0.0, 0.0),
        rpy_rad=(roll, pitch, yaw),
        gyro_bias_rad_s=(float(gyro_bias[0]), float(gyro_bias[1]), float(gyro_bias[2])),
        acc_bias_m_s2=(float(acc_bias[0]), float(acc_bias[1]), float(acc_bias[2])),
        levelling_std_rad=max(noise, LEVELLING_STD_FLOOR_RAD),
        static_until_s=standstill_end_s(imu, gnss, k_end),
        gyro_bias_std_rad_s=(
            None
            if known_gyro is not None
            else (float(gyro_noise[0]), float(gyro_noise[1]), float(gyro_noise[2]))
        ),
    )
