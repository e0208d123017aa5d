"""Attitude-only georeferencing into a rotating table's NED frame (Method A raw input).

On a rotating table the IMU and the scanner turn about the table centre, which is the
origin: a point ``x_s`` measured at ``t`` goes to the table-centred NED frame as
``x_n = R_body_to_ned(t) @ (lever_arm_body_m + R_scanner_to_body @ x_s)`` (SPEC
section 5 without the position term), with the attitude corrected for the latency tau
(SPEC section 1: the record tagged ``t + tau`` is read). Nothing is extrapolated, nor
interpolated across a data gap of the attitude (`kinsync.trajectory.Trajectory.interpolate`).
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync.georef import validated_scanner_points
from kinsync.mount import Mount
from kinsync.trajectory import Trajectory

__all__ = [
    "georeference_attitude_only",
    "georeference_table_points",
]


def georeference_attitude_only(
    t: FloatArray,
    xs: FloatArray,
    corrected: Trajectory,
    mount: Mount,
    *,
    max_gap_s: float | None = None,
) -> FloatArray:
    """`georeference_table_points` on validated input, attitude already corrected for tau."""
    R_body_to_ned = corrected.interpolate(t, max_gap_s=max_gap_s).R_body_to_ned
    x_body = mount.lever_arm_body_m_array + xs @ mount.R_scanner_to_body.T
    out: FloatArray = np.einsum("nij,nj->ni", R_body_to_ned, x_body)
    return out


def georeference_table_points(
    t_s: ArrayLike,
    points_scanner_m: ArrayLike,
    attitude: Trajectory,
    mount: Mount,
    *,
    max_gap_s: float | None = None,
) -> FloatArray:
    """Georeference scanner points into the table-centred NED frame (attitude only).

    ``x_ned = R_body_to_ned(t) @ (lever_arm_body_m + R_scanner_to_body @ x_scanner)``,
    the attitude read from ``attitude.corrected_for_latency(mount.latency_s)`` at the
    point times, i.e. from the record tagged ``t + tau`` (SPEC section 1). Positions of
    the trajectory are not used: the table centre is the origin.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s), the scanner's time scale.
    points_scanner_m : array_like, shape (N, 3)
        Points in the scanner frame (m).
    attitude : Trajectory
        Attitude records at their tags (body FRD -> table-centred NED), not yet
        corrected for latency.
    mount : Mount
        Lever arm (m, body), boresight scanner -> body and latency tau (s).
    max_gap_s : float, optional
        Longest attitude record interval (s) interpolated across; default
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals.

    Returns
    -------
    ndarray, shape (N, 3)
        Points in the table-centred NED frame (m).

    Raises
    ------
    InputError
        Mismatched shapes or non-finite input.
    OutsideSpanError
        A point time outside the corrected attitude span (never extrapolated) or inside
        one of its data gaps (never interpolated across; `kinsync.trajectory_gaps`).
    """
    t, xs = validated_scanner_points(t_s, points_scanner_m, "georeference_table_points")
    corrected = attitude.corrected_for_latency(mount.latency_s)
    return georeference_attitude_only(t, xs, corrected, mount, max_gap_s=max_gap_s)
