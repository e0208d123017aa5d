"""A navigation solution's errors: a truth perturbed by smooth, correlated noise.

`noisy_trajectory` stands in for an INS/GNSS solution: position and attitude errors
that are correlated in time (filtered white noise), as real trajectory errors are.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from kinsync._validate import positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    geodetic_to_ecef,
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
    skew,
)
from kinsync.ins.earth import radii_m
from kinsync.sim._common import _NOISE_STREAM, Vector3, _non_negative
from kinsync.trajectory import Trajectory

__all__ = [
    "gauss_markov_trajectory",
    "noisy_trajectory",
]


def gauss_markov_trajectory(
    truth: Trajectory, *, std_m: float, corr_time_s: float, seed: int
) -> Trajectory:
    """The truth plus an isotropic first-order Gauss-Markov position error.

    Each NED component follows ``e_k = phi e_(k-1) + sigma sqrt(1 - phi^2) w_k`` with
    ``phi = exp(-dt / corr_time_s)``: stationary, sigma ``std_m``, correlation
    ``exp(-|dt| / corr_time_s)`` (the model Method B's generalised least squares
    assumes). Velocities get the error's rate; the attitude is left true.

    Parameters
    ----------
    truth : Trajectory
        Geodetic trajectory with velocities.
    std_m : float
        Position error sigma per NED axis (m), >= 0.
    corr_time_s : float
        Correlation time (s), > 0.
    seed : int
        Seed (same seed, same errors).

    Returns
    -------
    Trajectory
        Same times and attitude; perturbed ``lat_lon_h`` and ``vel_ned_m_s``.
    """
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "gauss_markov_trajectory: the truth must be geodetic with velocities"
        raise InputError(msg)
    sigma = _non_negative(std_m, "std_m")
    tau = positive_number(corr_time_s, "corr_time_s")
    rng = np.random.default_rng([int(seed), 31])
    t = truth.t_s
    phi = np.exp(-np.diff(t) / tau)
    w = rng.normal(0.0, sigma, (t.size, 3))
    err = np.empty_like(w)
    err[0] = w[0]
    gain = np.sqrt(1.0 - phi**2)
    for k in range(1, t.size):
        err[k] = phi[k - 1] * err[k - 1] + gain[k - 1] * w[k]
    llh = truth.lat_lon_h
    R = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2]) + np.einsum("nij,nj->ni", R, err)
    return Trajectory(
        t_s=t,
        q_body_to_ned=truth.q_body_to_ned,
        lat_lon_h=ecef_to_geodetic(ecef),
        vel_ned_m_s=truth.vel_ned_m_s + np.gradient(err, t, axis=0),
    )


def noisy_trajectory(
    truth: Trajectory,
    *,
    std_pos_ned_m: Vector3 = (0.02, 0.02, 0.03),
    std_att_deg: Vector3 = (0.005, 0.005, 0.015),
    corr_time_s: float = 5.0,
    seed: int = 0,
) -> Trajectory:
    """A navigation solution: the truth with smooth, correlated position/attitude errors.

    Each error component is a natural cubic spline through independent N(0, sigma^2)
    knots ``corr_time_s`` apart (smooth, correlated over about ``corr_time_s``, RMS
    close to sigma). Position errors are NED (m); attitude errors are small rotations
    about the NED axes (roll, pitch, yaw order of ``std_att_deg``: N, E, D), applied as
    ``R' = (I + [e x]) R``. Velocities get the spline's derivative, so positions and
    velocities stay consistent for Hermite interpolation.

    Parameters
    ----------
    truth : Trajectory
        Geodetic trajectory with velocities.
    std_pos_ned_m : (float, float, float)
        Position error sigma N, E, D (m), >= 0.
    std_att_deg : (float, float, float)
        Misorientation sigma about N, E, D (deg), >= 0.
    corr_time_s : float
        Knot spacing of the error splines (s), > 0.
    seed : int
        Seed (same seed, same errors).

    Returns
    -------
    Trajectory
        Same times; perturbed ``lat_lon_h``, ``q_body_to_ned`` and ``vel_ned_m_s``.
    """
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "noisy_trajectory: the truth must be geodetic with velocities"
        raise InputError(msg)
    sp = np.array([_non_negative(v, "std_pos_ned_m") for v in std_pos_ned_m])
    sa = np.radians([_non_negative(v, "std_att_deg") for v in std_att_deg])
    tau = positive_number(corr_time_s, "corr_time_s")
    rng = np.random.default_rng([int(seed), _NOISE_STREAM])
    n_knots = max(4, math.ceil(truth.duration_s / tau) + 2)
    knots = truth.t_start_s + tau * (np.arange(n_knots) - 1.0)
    spline = CubicSpline(knots, rng.normal(0.0, 1.0, (n_knots, 6)), bc_type="natural")
    e = spline(truth.t_s)
    de = spline(truth.t_s, 1)
    dp, ea = e[:, :3] * sp, e[:, 3:] * sa
    llh = truth.lat_lon_h
    lat = np.radians(llh[:, 0])
    r_m, r_n = radii_m(lat)
    new_llh = np.column_stack(
        [
            llh[:, 0] + np.degrees(dp[:, 0] / (r_m + llh[:, 2])),
            llh[:, 1] + np.degrees(dp[:, 1] / ((r_n + llh[:, 2]) * np.cos(lat))),
            llh[:, 2] - dp[:, 2],
        ]
    )
    new_llh[:, 1] = (new_llh[:, 1] + 180.0) % 360.0 - 180.0
    small = np.eye(3)[None, :, :] + skew(ea)
    R = np.einsum("nij,njk->nik", small, quaternion_to_matrix(truth.q_body_to_ned))
    u, _s, vt = np.linalg.svd(R)
    q = matrix_to_quaternion(u @ vt)
    return Trajectory(
        t_s=truth.t_s,
        q_body_to_ned=q,
        lat_lon_h=new_llh,
        vel_ned_m_s=truth.vel_ned_m_s + de[:, :3] * sp,
    )
