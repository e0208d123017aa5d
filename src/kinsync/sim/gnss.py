"""Drive simulation, the GNSS receiver: antenna positions and velocities with noise.

`simulate_gnss` gives antenna positions (the lever arm rotated by the true attitude)
and velocities (with ``w_eb x l``), white noise per axis, epochs at whole multiples of
the period, outages removed.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, section 14.2 (lever arm).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    geodetic_to_ecef,
    rotation_ned_to_ecef,
)
from kinsync.ins.earth import radii_m
from kinsync.ins.measurements import GnssData
from kinsync.sim._common import _GNSS_STREAM, Vector3, _vector3
from kinsync.sim.drive_truth import DriveTrajectory
from kinsync.sim.imu import _earth_and_transport_rate_ned
from kinsync.trajectory import Trajectory

__all__ = [
    "simulate_gnss",
]


def _outages(outages: object) -> tuple[tuple[float, float], ...]:
    if not isinstance(outages, Iterable):
        msg = f"GNSS outages: expected (start_s, end_s) pairs, got {outages!r}"
        raise InputError(msg)
    out: list[tuple[float, float]] = []
    for i, pair in enumerate(outages):
        if not isinstance(pair, Iterable) or len(vals := tuple(pair)) != 2:
            msg = f"GNSS outage {i}: expected a (start_s, end_s) pair, got {pair!r}"
            raise InputError(msg)
        start = finite_number(vals[0], f"GNSS outage {i} start_s")
        end = finite_number(vals[1], f"GNSS outage {i} end_s")
        if end <= start:
            msg = f"GNSS outage {i}: end {end} s must be after start {start} s"
            raise InputError(msg)
        out.append((start, end))
    return tuple(out)


def _body_rates_at(truth: Trajectory, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``w_nb`` in the body frame and NED velocity at times ``t`` (exact where possible)."""
    if isinstance(truth, DriveTrajectory) and truth.kinematics is not None:
        st = truth.state(t)
        return st.rate_nb_body_rad_s(), st.vel_ned_m_s
    if truth.vel_ned_m_s is None:
        msg = "simulate_gnss: the truth trajectory needs NED velocities (vel_ned_m_s)"
        raise InputError(msg)
    rate = truth.angular_rate_body_rad_s()
    w = np.column_stack([np.interp(t, truth.t_s, rate[:, i]) for i in range(3)])
    v = np.column_stack([np.interp(t, truth.t_s, truth.vel_ned_m_s[:, i]) for i in range(3)])
    return w, v


def simulate_gnss(
    truth: Trajectory,
    *,
    rate_hz: float = 5.0,
    std_pos_ned_m: Vector3 = (0.02, 0.02, 0.04),
    std_vel_ned_m_s: Vector3 = (0.01, 0.01, 0.02),
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0),
    outages: tuple[tuple[float, float], ...] = (),
    seed: int = 0,
) -> GnssData:
    """GNSS antenna fixes along a true trajectory (defaults: RTK at 5 Hz).

    Epochs at whole multiples of ``1 / rate_hz`` within the truth's span (receivers
    align their epochs to GPS time). Antenna position ``p + C_b^n l`` (exact, through
    ECEF), antenna velocity ``v + C_b^n (w_eb x l)`` with ``w_eb = w_nb + C_n^b w_en``
    (expressed in NED at the antenna); white Gaussian noise per NED axis; epochs inside
    an outage ``[start_s, end_s]`` removed; the sigmas given are written per epoch.

    Parameters
    ----------
    truth : Trajectory
        Geodetic true trajectory of the IMU with velocities (a `DriveTrajectory` gives
        exact angular rates; otherwise they are interpolated).
    rate_hz : float
        Epoch rate (Hz).
    std_pos_ned_m : (float, float, float)
        Position noise sigma N, E, D (m), > 0.
    std_vel_ned_m_s : (float, float, float)
        Velocity noise sigma N, E, D (m/s), > 0.
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna phase centre, body frame FRD (m).
    outages : tuple of (start_s, end_s)
        Intervals without fixes (s, the truth's time scale).
    seed : int
        Seed of the noise (same seed, same data).

    Returns
    -------
    GnssData

    Raises
    ------
    InputError
        Bad rate, sigma, lever arm or outage; fewer than 2 epochs left.
    """
    if truth.lat_lon_h is None:
        msg = "simulate_gnss: the truth trajectory must be geodetic (lat_lon_h)"
        raise InputError(msg)
    rate = positive_number(rate_hz, "GNSS rate_hz")
    std_p = np.array([positive_number(v, "GNSS std_pos_ned_m") for v in std_pos_ned_m])
    std_v = np.array([positive_number(v, "GNSS std_vel_ned_m_s") for v in std_vel_ned_m_s])
    if std_p.size != 3 or std_v.size != 3:
        msg = "GNSS std_pos_ned_m and std_vel_ned_m_s: expected 3 values each"
        raise InputError(msg)
    arm = np.array(_vector3(antenna_lever_arm_body_m, "antenna_lever_arm_body_m"))
    k0 = math.ceil(truth.t_start_s * rate - 1e-9)
    k1 = math.floor(truth.t_end_s * rate + 1e-9)
    t = np.arange(k0, k1 + 1, dtype=np.float64) / rate
    t = t[(t >= truth.t_start_s) & (t <= truth.t_end_s)]
    keep = np.ones(t.size, dtype=np.bool_)
    for start, end in _outages(outages):
        keep &= ~((t >= start) & (t <= end))
    t = t[keep]
    if t.size < 2:
        msg = (
            f"GNSS: {t.size} epoch(s) left at {rate} Hz over the truth's "
            f"{truth.duration_s:.3f} s after the outages; shorten the outages or raise the rate"
        )
        raise InputError(msg)
    sample = truth.interpolate(t)
    assert sample.lat_lon_h is not None
    llh = sample.lat_lon_h
    R_bn = sample.R_body_to_ned
    w_nb, vel = _body_rates_at(truth, t)
    lat = np.radians(llh[:, 0])
    _w_ie, w_en = _earth_and_transport_rate_ned(lat, llh[:, 2], vel)
    w_eb = w_nb + np.einsum("nji,nj->ni", R_bn, w_en)
    R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    arm_ned = np.einsum("nij,j->ni", R_bn, arm)
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2]) + np.einsum(
        "nij,nj->ni", R_ne, arm_ned
    )
    ant = ecef_to_geodetic(ecef)
    v_ecef = np.einsum("nij,nj->ni", R_ne, vel + np.einsum("nij,nj->ni", R_bn, np.cross(w_eb, arm)))
    R_ne_ant = rotation_ned_to_ecef(ant[:, 0], ant[:, 1])
    v_ant = np.einsum("nji,nj->ni", R_ne_ant, v_ecef)
    rng = np.random.default_rng([int(seed), _GNSS_STREAM])
    dp = rng.normal(0.0, 1.0, (t.size, 3)) * std_p
    dv = rng.normal(0.0, 1.0, (t.size, 3)) * std_v
    lat_a = np.radians(ant[:, 0])
    r_m, r_n = radii_m(lat_a)
    lat_deg = ant[:, 0] + np.degrees(dp[:, 0] / (r_m + ant[:, 2]))
    lon_deg = ant[:, 1] + np.degrees(dp[:, 1] / ((r_n + ant[:, 2]) * np.cos(lat_a)))
    return GnssData(
        t_s=t,
        lat_deg=lat_deg,
        lon_deg=(lon_deg + 180.0) % 360.0 - 180.0,
        h_m=ant[:, 2] - dp[:, 2],
        std_pos_ned_m=np.tile(std_p, (t.size, 1)),
        vel_ned_m_s=v_ant + dv,
        std_vel_ned_m_s=np.tile(std_v, (t.size, 1)),
    )
