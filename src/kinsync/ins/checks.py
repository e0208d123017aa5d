"""Plausibility checks of INS/GNSS inputs before filtering.

Pure functions on the containers (`ImuData`, `GnssData`, `InsConfig`): nothing is read
from files; ``imu_source`` and ``gnss_source`` only name the inputs in messages. Rows
are 0-based data rows of the containers (in a CSV file with a header, row ``k`` is on
line ``k + 2``).

Errors (`InputError`, the filter must not run):

- a gap between IMU samples longer than ``InsConfig.max_imu_gap_s`` (a median interval
  that long: times in ms or µs, or, when the median interval is that of an IMU in seconds
  (at most `IMU_MAX_INTERVAL_S`), a ``max_imu_gap_s`` below the sampling interval);
- fewer than two GNSS epochs inside the IMU time span (different time scales?), or
  epochs there a median of more than 10 s apart (GNSS times in ms or µs);
- specific force whose median magnitude is far from 1 g (0.5 g to 1.5 g accepted):
  units of g, ft/s^2, or counts;
- a median specific force on Z above +0.7 of that magnitude (Z up: X forward, Y left,
  Z up axes), or on X or Y beyond ±0.7 (gravity along a horizontal axis: columns out of
  order);
- angular rates whose median magnitude exceeds 1 rad/s (57 deg/s): rates in deg/s;
- a static start (small accelerometer scatter and, where the GNSS gives velocities,
  GNSS speed below 0.5 m/s over the first ``static_s`` seconds) whose mean specific
  force differs from normal gravity by more than 10 %, or whose mean angular rate
  exceeds 1 rad/s.

Warnings (returned as text, the filter may run):

- GNSS epochs outside the IMU span (they are not used; see `gnss_within_imu_span`);
- IMU intervals longer than 1.5 times the median interval (missing samples) but within
  the tolerated gap;
- GNSS outages longer than 10 s (between epochs, or at the start or end of the IMU span);
- a static start whose gravity magnitude is off by 2 % to 10 %;
- a median angular rate between 0.3 and 1 rad/s (unusual for a land or sea vehicle);
- an antenna lever arm with Z > 0 (antenna below the IMU in Forward-Right-Down: usually
  a sign slip, which the data cannot reveal on level ground).

Initial state (`check_initial_state`, errors): roll beyond ±π, pitch beyond ±π/2 or
yaw outside [-π, 2π] (angles given in degrees), and a position more than
`MAX_INITIAL_OFFSET_M` (plus the lever arm and `MAX_SPEED_M_S` times the time between
them) from the GNSS fix nearest in time (degrees given in radians, latitude and
longitude swapped, a lost sign, or the state of another data set).

After filtering (`check_gnss_rejections`): the χ² gate rejects about
``1 - gate_probability`` of the GNSS epochs when the filter's model fits the data. A
filter that rejects many more disagrees with its GNSS, whatever the cause (rates in
deg/s on a drive too calm for the median test above, wrong axes, a GNSS time offset,
a wrong lever arm or initial state): more than `GATE_WARNING_SHARE` rejected is a
warning, more than `GATE_ERROR_SHARE` an error (the solution no longer follows its
GNSS: deg/s rates on a calm 2 m/s drive gave 30 %, GNSS tagged 0.2 s late 36 %); each
share is at least `GATE_RATE_FACTOR` times the gate's own rate ``1 - gate_probability``
(`InsConfig` keeps it at or below 10 %).
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync._unix_time import unix_offset_text
from kinsync.errors import ConvergenceError, InputError
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import normal_gravity_m_s2
from kinsync.ins.file_rows import MAX_LISTED, FileRows, rows_list
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState

__all__ = [
    "FileRows",
    "check_gnss_rejections",
    "check_initial_state",
    "check_inputs",
    "gnss_within_imu_span",
    "with_warnings",
]

G0_M_S2 = 9.80665
FT_M = 0.3048
STATIC_ACC_STD_M_S2 = 0.3
"""Largest per-axis accelerometer scatter (m/s^2) of a static start."""
STATIC_GNSS_SPEED_M_S = 0.5
"""Largest GNSS speed (m/s) during a static start."""
GRAVITY_ERROR_REL = 0.10
GRAVITY_WARNING_REL = 0.02
GYRO_ERROR_RAD_S = 1.0
GYRO_WARNING_RAD_S = 0.3
GNSS_OUTAGE_S = 10.0
"""GNSS intervals longer than this (s) are outages; a median interval longer is an error."""
VERTICAL_SHARE = 0.7
"""A median specific force on one axis beyond this share of its magnitude: that axis is
vertical (X, Y, or Z pointing up: axes or signs that are not Forward-Right-Down)."""
GATE_WARNING_SHARE = 0.01
"""Share of GNSS epochs rejected by the χ² gate above which `check_gnss_rejections`
warns (or `GATE_RATE_FACTOR` times the gate's own rejection rate, if larger), when the
count is also beyond the chance of a filter that fits (binomial, `GATE_FALSE_ALARM`)."""
GATE_ERROR_SHARE = 0.2
"""Share of GNSS epochs rejected above which `check_gnss_rejections` refuses the run (or
`GATE_RATE_FACTOR` times the gate's own rejection rate, if larger)."""
GATE_RATE_FACTOR = 3.0
GATE_VERTICAL_SIGMA = 3.0
"""Median |down position innovation| (in its σ) of the rejected epochs beyond which, with
the north and east ones within `GATE_HORIZONTAL_SIGMA`, `check_gnss_rejections` names the
GNSS heights as the likely cause (a filter that fits has a median of 0.67 on each axis).
Measured on a simulated 120 s drive (median N, E, D): heights in feet 0.65, 0.71, 5.3; a
0.3 m height step 0.12, 0.06, 6.7; a vertical σ 2 to 4 times too small 0.6-0.8, 0.6-0.7,
5.2-5.8; but GNSS times 0.2 s late 2.3, 2.9, 0.67, UTC for GPS 66, 64, 1.2, a longitude of
the wrong sign 0.06, 88, 1.1, and gyro rates in deg/s (a diverging solution) 19, 4.0, 8.1."""
GATE_HORIZONTAL_SIGMA = 1.5
"""Largest median |north| and |east| innovation (in σ) of the rejected epochs for which
`check_gnss_rejections` blames the heights (`GATE_VERTICAL_SIGMA`)."""
GATE_FALSE_ALARM = 1e-3
MAX_INITIAL_OFFSET_M = 1000.0
"""Largest horizontal distance (m) between the initial position and the GNSS fix nearest
in time (beyond the lever arm and `MAX_SPEED_M_S` times the time between them)."""
MAX_SPEED_M_S = 300.0
"""Speed (m/s) allowed for the time between the initial state and that GNSS fix."""
EARTH_RADIUS_M = 6.371e6
IMU_MAX_INTERVAL_S = 0.1
"""Longest median IMU sampling interval (s, 10 Hz) taken as times in seconds: a longer one
exceeding ``max_imu_gap_s`` means times in ms or µs, a shorter one a gap set too small."""


def _check_gaps(
    imu: ImuData,
    config: InsConfig,
    source: str,
    config_source: str = "the configuration",
    names: FileRows | None = None,
) -> list[str]:
    rows_of = names or FileRows()
    dt = np.diff(imu.t_s)
    long_gap = np.flatnonzero(dt > config.max_imu_gap_s)
    if long_gap.size:
        k = int(long_gap[0]) + 1
        msg = (
            f"{source}: {long_gap.size} gap(s) between IMU samples longer than "
            f"max_imu_gap_s = {config.max_imu_gap_s:g} s; the first between rows "
            f"{rows_of.row(k - 1)} and {rows_of.row(k)} (t_s {imu.t_s[k - 1]:.6f} -> "
            f"{imu.t_s[k]:.6f}, {dt[k - 1]:.6g} s). Fill or split the record, or raise "
            "[filter] max_imu_gap_s in the configuration"
        )
        median_dt = float(np.median(dt))
        if config.max_imu_gap_s < median_dt <= IMU_MAX_INTERVAL_S:
            msg = (
                f"{config_source}: [filter] max_imu_gap_s = {config.max_imu_gap_s:g} s is "
                f"below the IMU's median sampling interval {median_dt:.6g} s ({source}): "
                "every interval counts as a gap. Set it above the sampling interval (a few "
                "intervals, e.g. 0.1 s)"
            )
        elif median_dt > config.max_imu_gap_s:
            msg = (
                f"{source}: the IMU samples are a median {median_dt:.6g} s apart (rows "
                f"{rows_of.row(0)} and {rows_of.row(1)} at t_s {imu.t_s[0]:.6f}, "
                f"{imu.t_s[1]:.6f}), where an IMU samples at 50-1000 Hz: are the times in ms "
                "or us? Give t_s in seconds"
            )
        raise InputError(msg)
    warnings: list[str] = []
    median = float(np.median(dt))
    slow = np.flatnonzero(dt > 1.5 * median)
    if slow.size:
        worst = int(slow[np.argmax(dt[slow])]) + 1
        rows = rows_list([int(s) + 1 for s in slow], names)
        warnings.append(
            f"{source}: {slow.size} interval(s) longer than 1.5 x the median sampling "
            f"interval {median:.6g} s (missing samples?), before rows {rows}; "
            f"the longest {dt[worst - 1]:.6g} s before row {rows_of.row(worst)} "
            f"(t_s {imu.t_s[worst]:.6f})"
        )
    return warnings


def _inside_span(gnss: GnssData, imu: ImuData) -> BoolArray:
    inside: BoolArray = (gnss.t_s >= imu.t_s[0]) & (gnss.t_s <= imu.t_s[-1])
    return inside


_LEAP_SECONDS = range(10, 19)
"""Whole seconds GPS time has run ahead of UTC (10 s in 1995 to 18 s since 2017)."""


def _leap_offset(imu: ImuData, gnss: GnssData, imu_source: str, gnss_source: str) -> list[str]:
    """A warning when the GNSS log starts and ends a whole leap-second count before the IMU's.

    GNSS times in UTC against IMU times in GPS time: the filter then meets positions
    10 to 18 s old and its chi-square gate rejects them. (The other way round, GNSS times
    late, `kinsync.ins.alignment` names it: no fix in the static start.)
    """
    head = float(gnss.t_s[0] - imu.t_s[0])
    tail = float(gnss.t_s[-1] - imu.t_s[-1])
    whole = round(head)
    spacing = float(np.median(np.diff(gnss.t_s))) if gnss.t_s.size > 1 else 0.0
    near = 0.5 + min(spacing, 1.0)  # the logs' ends differ by up to one GNSS interval
    if -whole not in _LEAP_SECONDS or abs(head - whole) >= near or abs(tail - whole) >= near:
        return []
    text = (
        f"{gnss_source}: the GNSS epochs start and end {-head:.3f} s and {-tail:.3f} s before "
        f"the IMU samples of {imu_source}: {-whole} s is what GPS time runs ahead of UTC "
        "(leap seconds; 18 s since 2017): are the GNSS times in UTC and the IMU's in GPS "
        "time? Put both on GPS time (add the leap seconds to the UTC times)"
    )
    return [text]


def _check_span(
    imu: ImuData, gnss: GnssData, imu_source: str, gnss_source: str, names: FileRows | None = None
) -> list[str]:
    rows_of = names or FileRows()
    inside = _inside_span(gnss, imu)
    n_in = int(np.count_nonzero(inside))
    spacing = float(np.median(np.diff(gnss.t_s))) if gnss.t_s.size > 1 else 0.0
    in_ms = (
        f"; its epochs are a median {spacing:.6g} s apart: are its times in ms or us?"
        if spacing > GNSS_OUTAGE_S
        else ""
    )
    if n_in < 2:
        unix = unix_offset_text(
            (float(imu.t_s[0]), float(imu.t_s[-1])),
            (float(gnss.t_s[0]), float(gnss.t_s[-1])),
            imu_source,
            gnss_source,
        )
        msg = (
            f"{gnss_source}: {n_in} GNSS epoch(s) inside the IMU span of {imu_source} "
            f"[{imu.t_s[0]:.6f}, {imu.t_s[-1]:.6f}] s (GNSS spans [{gnss.t_s[0]:.6f}, "
            f"{gnss.t_s[-1]:.6f}] s); at least 2 are needed: "
            + (
                unix
                or "are both files on the same time scale (GPS seconds of week vs continuous "
                f"GPS time, UTC vs GPS)?{in_ms}"
            )
        )
        raise InputError(msg)
    warnings = _leap_offset(imu, gnss, imu_source, gnss_source)
    outside = np.flatnonzero(~inside)
    if outside.size:
        warnings.append(
            f"{gnss_source}: {outside.size} GNSS epoch(s) outside the IMU span "
            f"[{imu.t_s[0]:.6f}, {imu.t_s[-1]:.6f}] s are not used (rows "
            f"{rows_list(outside.tolist(), names)})"
        )
    t_in = gnss.t_s[inside]
    rows_in = np.flatnonzero(inside)
    gaps = np.diff(t_in)
    median_gap = float(np.median(gaps))
    if median_gap > GNSS_OUTAGE_S:
        msg = (
            f"{gnss_source}: the {n_in} GNSS epochs inside the IMU span of {imu_source} "
            f"[{imu.t_s[0]:.6f}, {imu.t_s[-1]:.6f}] s are a median {median_gap:.6g} s apart "
            f"(GNSS spans [{gnss.t_s[0]:.6f}, {gnss.t_s[-1]:.6f}] s, {gnss.t_s.size} epochs), "
            "where the filter needs a position every few seconds: are the GNSS times in ms "
            "or us, or on another time scale than the IMU's? Give both in GPS seconds"
        )
        raise InputError(msg)
    warnings.extend(
        f"{gnss_source}: GNSS outage of {gaps[k]:.3f} s between rows "
        f"{rows_of.row(rows_in[k])} and {rows_of.row(rows_in[k + 1])} (t_s {t_in[k]:.3f} "
        f"-> {t_in[k + 1]:.3f}); the solution drifts on the IMU alone there"
        for k in np.flatnonzero(gaps > GNSS_OUTAGE_S).tolist()
    )
    head, tail = t_in[0] - imu.t_s[0], imu.t_s[-1] - t_in[-1]
    if head > GNSS_OUTAGE_S:
        warnings.append(
            f"{gnss_source}: no GNSS epoch in the first {head:.3f} s of the IMU span "
            f"(first used epoch at t_s {t_in[0]:.3f}, {rows_of.where(rows_in[0])})"
        )
    if tail > GNSS_OUTAGE_S:
        warnings.append(
            f"{gnss_source}: no GNSS epoch in the last {tail:.3f} s of the IMU span "
            f"(last used epoch at t_s {t_in[-1]:.3f}, {rows_of.where(rows_in[-1])})"
        )
    return warnings


def _units_hint(value_m_s2: float) -> str:
    for unit, scale in (("g", G0_M_S2), ("ft/s^2", FT_M)):
        as_si = value_m_s2 * scale
        if abs(as_si - G0_M_S2) < 0.15 * G0_M_S2:
            return f"; it looks like {unit}: multiply by {scale:g} to get m/s^2"
    return "; expected specific force in m/s^2 (about 9.8 when static)"


def _check_units(imu: ImuData, source: str) -> list[str]:
    acc_norm = np.linalg.norm(imu.acc_body_m_s2, axis=1)
    med_acc = float(np.median(acc_norm))
    if not 0.5 * G0_M_S2 <= med_acc <= 1.5 * G0_M_S2:
        msg = (
            f"{source}: the median specific-force magnitude is {med_acc:.6g} m/s^2, far from "
            f"gravity (9.8){_units_hint(med_acc)}"
        )
        raise InputError(msg)
    med_axes = np.median(imu.acc_body_m_s2, axis=0)
    if med_axes[2] > VERTICAL_SHARE * med_acc:
        msg = (
            f"{source}: the median specific force on the Z axis is {med_axes[2]:+.4g} m/s^2: "
            "Z points up, where kinsync's body axes are X forward, Y right, Z down (a "
            "vehicle's Z reads about -9.8); from X forward, Y left, Z up, negate the Y and Z "
            "columns of the rates and the specific force"
        )
        raise InputError(msg)
    side = int(np.argmax(np.abs(med_axes[:2])))
    if abs(med_axes[side]) > VERTICAL_SHARE * med_acc:
        msg = (
            f"{source}: the median specific force on the {'XY'[side]} axis is "
            f"{med_axes[side]:+.4g} m/s^2, so gravity lies along {'XY'[side]}; kinsync's body "
            "axes are X forward, Y right, Z down (a vehicle's Z reads about -9.8): reorder "
            "the columns"
        )
        raise InputError(msg)
    med_gyro = float(np.median(np.linalg.norm(imu.gyro_body_rad_s, axis=1)))
    if med_gyro > GYRO_ERROR_RAD_S:
        msg = (
            f"{source}: the median angular-rate magnitude is {med_gyro:.6g} rad/s "
            f"({math.degrees(med_gyro):.4g} deg/s), implausible for a vehicle; are the "
            "rates in deg/s? Convert them to rad/s (multiply by pi/180)"
        )
        raise InputError(msg)
    if med_gyro > GYRO_WARNING_RAD_S:
        text = (
            f"{source}: the median angular-rate magnitude is {med_gyro:.4g} rad/s "
            f"({math.degrees(med_gyro):.4g} deg/s), unusually high; check that the rates "
            "are in rad/s"
        )
        return [text]
    return []


def _check_static_start(
    imu: ImuData, gnss: GnssData, source: str, static_s: float, names: FileRows | None = None
) -> list[str]:
    window = imu.t_s <= imu.t_s[0] + static_s
    if np.count_nonzero(window) < 10:
        return []
    acc = imu.acc_body_m_s2[window]
    if (acc.std(axis=0) > STATIC_ACC_STD_M_S2).any():
        return []
    in_window = (gnss.t_s >= imu.t_s[0]) & (gnss.t_s <= imu.t_s[0] + static_s)
    if gnss.vel_ned_m_s is not None and in_window.any():
        speed = np.linalg.norm(gnss.vel_ned_m_s[in_window], axis=1)
        if (speed > STATIC_GNSS_SPEED_M_S).any():
            return []
    n_rows = int(np.count_nonzero(window))
    rows_of = names or FileRows()
    first_line, last_line = rows_of.line(0), rows_of.line(n_rows - 1)
    lines = "" if first_line is None else f", lines {first_line}-{last_line}"
    where = f"{source}: static start (rows 0-{n_rows - 1}{lines}, first {static_s:g} s)"
    gyro_mean = float(np.linalg.norm(imu.gyro_body_rad_s[window].mean(axis=0)))
    if gyro_mean > GYRO_ERROR_RAD_S:
        msg = (
            f"{where}: mean angular rate {gyro_mean:.6g} rad/s where a static gyro reads "
            "Earth rate and bias only (< 0.01 rad/s); check the gyro units (rad/s) and scale"
        )
        raise InputError(msg)
    g_meas = float(np.linalg.norm(acc.mean(axis=0)))
    k0 = int(np.argmin(np.abs(gnss.t_s - imu.t_s[0])))
    g_normal = float(normal_gravity_m_s2(math.radians(gnss.lat_deg[k0]), float(gnss.h_m[k0])))
    rel = abs(g_meas - g_normal) / g_normal
    text = (
        f"{where}: mean specific-force magnitude {g_meas:.6g} m/s^2 differs from normal "
        f"gravity {g_normal:.6g} m/s^2 by {100.0 * rel:.3g} %"
    )
    if rel > GRAVITY_ERROR_REL:
        msg = f"{text}{_units_hint(g_meas)}; or the accelerometer scale is wrong"
        raise InputError(msg)
    if rel > GRAVITY_WARNING_REL:
        return [f"{text}; check the accelerometer scale and units"]
    return []


def check_inputs(
    imu: ImuData,
    gnss: GnssData,
    config: InsConfig,
    *,
    imu_source: str = "imu.csv",
    gnss_source: str = "gnss.csv",
    static_s: float = 2.0,
    config_source: str = "the configuration",
    imu_rows: FileRows | None = None,
    gnss_rows: FileRows | None = None,
) -> list[str]:
    """Check IMU and GNSS inputs for gaps, time-span mismatch and wrong units.

    Parameters
    ----------
    imu : ImuData
        IMU samples (times already strictly increasing: `ImuData` enforces it).
    gnss : GnssData
        GNSS epochs.
    config : InsConfig
        Filter configuration (``max_imu_gap_s``).
    imu_source, gnss_source : str
        Names of the inputs used in messages (usually the file paths).
    static_s : float
        Length (s) of the start window tested for a static start.
    config_source : str
        Name of the configuration in messages (its file path).
    imu_rows, gnss_rows : FileRows, optional
        The file rows and lines of the inputs' rows, for messages (default: their rows).

    Returns
    -------
    list of str
        Warnings, each naming its input, rows (and lines) and times (empty when all is
        well).

    Raises
    ------
    InputError
        For the errors listed in the module docstring, naming the input, rows and times
        and what to do.
    """
    warnings: list[str] = []
    warnings += _check_gaps(imu, config, imu_source, config_source, imu_rows)
    warnings += _check_span(imu, gnss, imu_source, gnss_source, gnss_rows)
    warnings += _check_units(imu, imu_source)
    warnings += _check_static_start(imu, gnss, imu_source, static_s, imu_rows)
    arm_z = config.antenna_lever_arm_body_m[2]
    if arm_z > 0.0:
        warnings.append(
            f"antenna_lever_arm_body_m z = {arm_z:+g} m puts the GNSS antenna {arm_z:g} m "
            "below the IMU (body axes X forward, Y right, Z down); an antenna is usually "
            "above it (z < 0). The data cannot tell a wrong sign on level ground: the heights "
            "would be off by twice the value. Check the sign"
        )
    return warnings


def _take(arr: FloatArray | None, keep: BoolArray) -> FloatArray | None:
    return None if arr is None else arr[keep]


def gnss_within_imu_span(gnss: GnssData, imu: ImuData) -> GnssData:
    """The GNSS epochs inside the IMU span ``[imu.t_s[0], imu.t_s[-1]]``.

    Raises
    ------
    InputError
        Fewer than 2 epochs inside the span.
    """
    keep = _inside_span(gnss, imu)
    if np.count_nonzero(keep) < 2:
        msg = (
            f"only {int(np.count_nonzero(keep))} GNSS epoch(s) inside the IMU span "
            f"[{imu.t_s[0]:.6f}, {imu.t_s[-1]:.6f}] s; at least 2 are needed"
        )
        raise InputError(msg)
    if keep.all():
        return gnss
    return GnssData(
        t_s=gnss.t_s[keep],
        lat_deg=gnss.lat_deg[keep],
        lon_deg=gnss.lon_deg[keep],
        h_m=gnss.h_m[keep],
        std_pos_ned_m=gnss.std_pos_ned_m[keep],
        vel_ned_m_s=_take(gnss.vel_ned_m_s, keep),
        std_vel_ned_m_s=_take(gnss.std_vel_ned_m_s, keep),
    )


def _vertical_cause(rejected_nu_ned: FloatArray | None) -> str:
    """The height diagnosis when the rejected epochs disagree on the down axis; else "".

    ``rejected_nu_ned`` (r, 3): the rejected epochs' position innovations over their σ.
    """
    if rejected_nu_ned is None:
        return ""
    nu = np.asarray(rejected_nu_ned, dtype=np.float64).reshape(-1, 3)
    nu = nu[np.isfinite(nu).all(axis=1)]
    if not nu.shape[0]:
        return ""
    north, east, down = (float(v) for v in np.median(np.abs(nu), axis=0))
    if down < GATE_VERTICAL_SIGMA or max(north, east) > GATE_HORIZONTAL_SIGMA:
        return ""
    return (
        f", nearly all for their height: the rejected GNSS heights lie a median {down:.3g} σ "
        f"from the filter's prediction, their north and east {north:.2g} σ and {east:.2g} σ. "
        "Check the GNSS height column h_m first: heights in feet (multiply by 0.3048), "
        "orthometric (geoid, mean-sea-level) heights mixed with ellipsoidal ones, or a jump "
        "in the heights at these epochs; then the vertical σ (std_d_m, [gnss] "
        "std_pos_ned_m) and the antenna lever arm's z"
    )


def check_gnss_rejections(
    rejected_t_s: FloatArray,
    n_used: int,
    config: InsConfig,
    *,
    gnss_source: str = "gnss.csv",
    rejected_nu_ned: FloatArray | None = None,
    rejected_rows: IntArray | None = None,
    gnss_rows: FileRows | None = None,
) -> list[str]:
    """Check how many GNSS epochs the filter's χ² gate rejected, and on which axis.

    Parameters
    ----------
    rejected_t_s : ndarray, shape (r,)
        Times of the rejected epochs (s), `kinsync.ins.filter.InsResult.gnss_rejected_t_s`.
    n_used : int
        Epochs that updated the filter.
    config : InsConfig
        Its ``gate_probability`` gives the rejection rate of a filter that fits.
    gnss_source : str
        Name of the GNSS input in messages.
    rejected_nu_ned : ndarray, shape (r, 3), optional
        The rejected epochs' position innovations N, E, D over their σ (unitless),
        `InsResult.rejected_innovations_pos_ned_m` over
        `InsResult.rejected_innovation_std_pos_ned_m`: when they lie on the down axis
        (`GATE_VERTICAL_SIGMA`, `GATE_HORIZONTAL_SIGMA`), the message names the GNSS
        heights as the likely cause.
    rejected_rows : ndarray of int, shape (r,), optional
        Rows of the rejected epochs in the GNSS data, named with their times.
    gnss_rows : FileRows, optional
        The file rows and lines of those rows.

    Returns
    -------
    list of str
        A warning when more than `GATE_WARNING_SHARE` (or `GATE_RATE_FACTOR` times the
        gate's rate) of the epochs were rejected, and more than a filter that fits would
        reject with probability `GATE_FALSE_ALARM`; else nothing.

    Raises
    ------
    InputError
        More than `GATE_ERROR_SHARE` of the epochs rejected.
    """
    from scipy.stats import binom  # noqa: PLC0415

    n_rej = int(rejected_t_s.size)
    n = n_rej + int(n_used)
    expected = 1.0 - config.gate_probability
    if n == 0 or n_rej < 3:
        return []
    share = n_rej / n
    by_chance = float(binom.isf(GATE_FALSE_ALARM, n, expected))
    refuse = share > max(GATE_ERROR_SHARE, GATE_RATE_FACTOR * expected)
    if not refuse and (
        share <= max(GATE_WARNING_SHARE, GATE_RATE_FACTOR * expected) or n_rej <= by_chance
    ):
        return []
    rows_of = gnss_rows or FileRows()
    listed = []
    for i, t in enumerate(rejected_t_s[:MAX_LISTED].tolist()):
        where = (
            f" ({rows_of.where(int(rejected_rows[i]))})"
            if rejected_rows is not None and i < len(rejected_rows)
            else ""
        )
        listed.append(f"{t:.3f}{where}")
    more = f" and {n_rej - MAX_LISTED} more" if n_rej > MAX_LISTED else ""
    head = (
        f"{gnss_source}: the chi-square gate rejected {n_rej} of {n} GNSS epochs "
        f"({n_rej / n:.1%}; a filter that fits its data rejects about {expected:.2%}) at "
        f"t_s {', '.join(listed)}{more}: the IMU and the GNSS disagree"
    )
    vertical = _vertical_cause(rejected_nu_ned)
    text = head + (
        vertical
        or (
            ". Check the gyro units (rad/s, not deg/s) and axes (X forward, Y right, Z "
            "down), a spike in an IMU record (one bad gyro or accelerometer value), the GNSS "
            "time tags (same time scale, no offset), the antenna lever arm, the initial "
            "state, the [init] biases, the [imu] bias sigma (units of their keys) and the "
            "[gnss] sigma"
        )
    )
    if refuse:
        msg = f"{text}; no solution written"
        raise InputError(msg)
    return [text]


_ATTITUDE_BOUNDS = (
    ("roll", -math.pi, math.pi, "±π"),
    ("pitch", -0.5 * math.pi, 0.5 * math.pi, "±π/2"),
    ("yaw", -math.pi, 2.0 * math.pi, "-π to 2π"),
)


def _distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Great-circle distance (m) on a sphere of radius `EARTH_RADIUS_M` (haversine)."""
    p1, p2 = math.radians(lat1_deg), math.radians(lat2_deg)
    dp, dl = p2 - p1, math.radians(lon2_deg - lon1_deg)
    a = math.sin(0.5 * dp) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(0.5 * dl) ** 2
    return 2.0 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


def check_initial_state(
    init: InitialState,
    gnss: GnssData,
    config: InsConfig,
    *,
    gnss_source: str = "gnss.csv",
    gnss_rows: FileRows | None = None,
) -> None:
    """Refuse an initial attitude or position that cannot be right (a unit mix-up).

    Parameters
    ----------
    init : InitialState
        The filter's initial state (finite values; non-finite ones are left to the
        filter's own message).
    gnss : GnssData
        GNSS epochs; the one nearest ``init.t_s`` in time is compared with the position.
    config : InsConfig
        Its antenna lever arm widens the distance accepted.
    gnss_source : str
        Name of the GNSS input in messages.
    gnss_rows : FileRows, optional
        The file rows and lines of ``gnss``'s rows, for messages.

    Raises
    ------
    InputError
        An angle of ``init.rpy_rad`` beyond its range (roll ±π, pitch ±π/2, yaw -π to
        2π): degrees where radians are expected; or a position farther from the
        nearest GNSS fix than `MAX_INITIAL_OFFSET_M` plus the lever arm plus
        `MAX_SPEED_M_S` times the time between them, naming the fields, the fix and the
        likely mix-up (radians where degrees are expected, latitude and longitude
        swapped).
    """
    try:
        rpy = [float(v) for v in init.rpy_rad]
        lat, lon, t0 = float(init.lat_deg), float(init.lon_deg), float(init.t_s)
    except (TypeError, ValueError):
        return  # the filter names the malformed state
    for i, (angle, (name, low, high, text)) in enumerate(zip(rpy, _ATTITUDE_BOUNDS, strict=False)):
        if math.isfinite(angle) and not low - 1e-9 <= angle <= high + 1e-9:
            msg = (
                f"initial state: rpy_rad[{i}] ({name}) = {angle:.6g} rad is beyond {text}: "
                f"is it in degrees? rpy_rad takes radians ({angle:.6g} deg = "
                f"{math.radians(angle):.6g} rad)"
            )
            raise InputError(msg)
    if not (math.isfinite(lat) and math.isfinite(lon) and math.isfinite(t0)) or not len(gnss):
        return
    j = int(np.argmin(np.abs(gnss.t_s - t0)))
    lat_g, lon_g, dt = float(gnss.lat_deg[j]), float(gnss.lon_deg[j]), abs(gnss.t_s[j] - t0)
    arm_m = math.hypot(*config.antenna_lever_arm_body_m)
    allowed_m = MAX_INITIAL_OFFSET_M + arm_m + MAX_SPEED_M_S * dt
    offset_m = _distance_m(lat, lon, lat_g, lon_g)
    if offset_m <= allowed_m:
        return
    hint = (
        "; check the initial position (degrees, WGS84; south and west negative): is it "
        "the state of this data set?"
    )
    if abs(lat) <= 0.5 * math.pi and abs(lon) <= 2.0 * math.pi:
        as_deg = _distance_m(math.degrees(lat), math.degrees(lon), lat_g, lon_g)
        if as_deg <= allowed_m:
            hint = (
                "; lat_deg and lon_deg look like radians: give degrees "
                f"({math.degrees(lat):.8g}, {math.degrees(lon):.8g})"
            )
    if abs(lon) <= 90.0 and _distance_m(lon, lat, lat_g, lon_g) <= allowed_m:
        hint = "; lat_deg and lon_deg look swapped: give the latitude first"
    msg = (
        f"initial state: lat_deg {lat:.8g}, lon_deg {lon:.8g} at t_s {t0:.3f} lies "
        f"{offset_m / 1000.0:.4g} km from the GNSS fix nearest in time ({gnss_source} "
        f"{(gnss_rows or FileRows()).where(j)}, t_s {gnss.t_s[j]:.3f}: lat_deg {lat_g:.8g}, "
        f"lon_deg {lon_g:.8g}), more than the {allowed_m / 1000.0:.4g} km a vehicle could "
        f"be from it{hint}"
    )
    raise InputError(msg)


def with_warnings(
    err: InputError | ConvergenceError, warnings: list[str]
) -> InputError | ConvergenceError:
    """``err`` as one line that ends with the input checks' ``warnings`` (a cause, maybe).

    ``kinsync ins run`` prints an error as one line and its warnings only after a run
    that succeeded, so a failed run's message carries them.
    """
    earlier = " | ".join(" ".join(w.split()) for w in warnings)
    return type(err)(f"{err}. The input checks had warned: {earlier}")
