"""Containers for inertial and GNSS measurements.

What the readers and the simulator produce and the filter consumes.

IMU: angular rate and specific force in the body frame (X forward, Y right, Z down),
sampled at times ``t_s``; the sample at ``t_s[k]`` is taken to represent the interval
``(t_s[k-1], t_s[k]]`` (increment data is converted to mean rates over that interval
at the file boundary). GNSS: antenna positions (geodetic, WGS84), optional NED
velocities, per-epoch standard deviations (NaN where the file gives none; the filter
then uses the configured defaults).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray
from kinsync._validate import coordinate_array, degree_array, time_array
from kinsync.errors import InputError
from kinsync.trajectory_rows import (
    HEIGHT_SPAN_M,
    LONGITUDE_SPAN_DEG,
    height_message,
    longitude_message,
)

__all__ = ["GnssData", "ImuData"]


def _owned(values: FloatArray) -> FloatArray:
    """A C-contiguous float64 copy: the container's own, never a view of the caller's."""
    return np.array(values, dtype=np.float64, copy=True, order="C")


def _rows(values: FloatArray, n: int, name: str, *, allow_nan: bool = False) -> FloatArray:
    arr = _owned(values)
    if arr.shape != (n, 3):
        msg = f"{name}: expected shape ({n}, 3), got {arr.shape}"
        raise InputError(msg)
    bad = ~np.isfinite(arr) & ~(np.isnan(arr) if allow_nan else False)
    if bad.any():
        row = int(np.flatnonzero(bad.any(axis=1))[0])
        msg = f"{name}: non-finite value in row {row}"
        raise InputError(msg)
    arr.setflags(write=False)
    return arr


def _times(values: FloatArray, name: str) -> FloatArray:
    t = _owned(time_array(values, name))
    if t.ndim != 1 or t.size < 2:
        msg = f"{name}: expected at least 2 times in a 1-D array, got shape {t.shape}"
        raise InputError(msg)
    if not np.isfinite(t).all():
        row = int(np.flatnonzero(~np.isfinite(t))[0])
        msg = f"{name}: non-finite time in row {row}"
        raise InputError(msg)
    dt = np.diff(t)
    if (dt <= 0).any():
        row = int(np.flatnonzero(dt <= 0)[0]) + 1
        kind = "duplicate" if dt[row - 1] == 0 else "decreasing"
        msg = (
            f"{name}: {kind} time in row {row} ({t[row]:.6f} s after {t[row - 1]:.6f} s); "
            "times must increase strictly - sort the file or remove repeated records"
        )
        raise InputError(msg)
    t.setflags(write=False)
    return t


@dataclass(frozen=True, eq=False)
class ImuData(ReadOnlyArrays):
    """IMU samples.

    The arrays are copied (the caller's stay as they are) and made read-only. Times are
    float seconds: datetime64, text, or a float dtype too coarse for 1 us (float32 beyond
    16 s) raise `InputError` naming the argument (`kinsync._validate.time_array`).

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Sample times (s), strictly increasing, on the navigation time scale.
    gyro_body_rad_s : ndarray, shape (n, 3)
        Angular rate of the body with respect to inertial space, body frame (rad/s).
    acc_body_m_s2 : ndarray, shape (n, 3)
        Specific force, body frame (m/s^2); about (0, 0, -9.8) when level and static.
    """

    t_s: FloatArray
    gyro_body_rad_s: FloatArray
    acc_body_m_s2: FloatArray

    def __post_init__(self) -> None:
        t = _times(self.t_s, "IMU t_s")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "gyro_body_rad_s", _rows(self.gyro_body_rad_s, t.size, "IMU gyro"))
        object.__setattr__(self, "acc_body_m_s2", _rows(self.acc_body_m_s2, t.size, "IMU acc"))

    def __len__(self) -> int:
        return int(self.t_s.size)


@dataclass(frozen=True, eq=False)
class GnssData(ReadOnlyArrays):
    """GNSS antenna fixes.

    The arrays are copied and made read-only. Times are checked as `ImuData`'s;
    latitudes, longitudes and heights in a float dtype too coarse for 0.1 mm (float32)
    raise `InputError` naming the argument (`kinsync._validate.degree_array`).

    Attributes
    ----------
    t_s : ndarray, shape (m,)
        Epoch times (s), strictly increasing.
    lat_deg, lon_deg, h_m : ndarray, shape (m,)
        Antenna position, WGS84 geodetic (deg, deg, m ellipsoidal); latitudes within
        +-90 deg, longitudes from -180 to 180 or 0 to 360 deg
        (`kinsync.trajectory_rows.LONGITUDE_SPAN_DEG`), heights within 100 km of the
        ellipsoid (`kinsync.trajectory_rows.HEIGHT_SPAN_M`).
    std_pos_ned_m : ndarray, shape (m, 3)
        Position standard deviations N, E, D (m); NaN = use the configured default.
    vel_ned_m_s : ndarray, shape (m, 3) or None
        Antenna velocity in NED (m/s), when the receiver gives it.
    std_vel_ned_m_s : ndarray, shape (m, 3) or None
        Velocity standard deviations (m/s); NaN = configured default.
    """

    t_s: FloatArray
    lat_deg: FloatArray
    lon_deg: FloatArray
    h_m: FloatArray
    std_pos_ned_m: FloatArray
    vel_ned_m_s: FloatArray | None = None
    std_vel_ned_m_s: FloatArray | None = None

    def __post_init__(self) -> None:
        t = _times(self.t_s, "GNSS t_s")
        n = t.size
        object.__setattr__(self, "t_s", t)
        for name in ("lat_deg", "lon_deg", "h_m"):
            check = coordinate_array if name == "h_m" else degree_array
            arr = _owned(check(getattr(self, name), f"GNSS {name}"))
            if arr.shape != (n,) or not np.isfinite(arr).all():
                msg = f"GNSS {name}: expected {n} finite values"
                raise InputError(msg)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if (np.abs(self.lat_deg) > 90.0).any():
            row = int(np.flatnonzero(np.abs(self.lat_deg) > 90.0)[0])
            msg = f"GNSS lat_deg: {self.lat_deg[row]} outside [-90, 90] in row {row}"
            raise InputError(msg)
        low, high = LONGITUDE_SPAN_DEG
        bad = (self.lon_deg < low) | (self.lon_deg > high)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            msg = f"GNSS lon_deg: {longitude_message(float(self.lon_deg[row]), row)}"
            raise InputError(msg)
        bad = (self.h_m < HEIGHT_SPAN_M[0]) | (self.h_m > HEIGHT_SPAN_M[1])
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            msg = f"GNSS h_m: {height_message(float(self.h_m[row]), row)}"
            raise InputError(msg)
        std = _rows(self.std_pos_ned_m, n, "GNSS std_pos_ned_m", allow_nan=True)
        if (std <= 0).any():
            msg = "GNSS std_pos_ned_m: standard deviations must be positive"
            raise InputError(msg)
        object.__setattr__(self, "std_pos_ned_m", std)
        if self.vel_ned_m_s is not None:
            object.__setattr__(self, "vel_ned_m_s", _rows(self.vel_ned_m_s, n, "GNSS velocity"))
        if self.std_vel_ned_m_s is not None:
            sv = _rows(self.std_vel_ned_m_s, n, "GNSS std_vel_ned_m_s", allow_nan=True)
            if (sv <= 0).any():
                msg = "GNSS std_vel_ned_m_s: standard deviations must be positive"
                raise InputError(msg)
            object.__setattr__(self, "std_vel_ned_m_s", sv)

    def __len__(self) -> int:
        return int(self.t_s.size)
