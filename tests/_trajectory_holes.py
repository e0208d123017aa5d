"""A trajectory with a data gap cut into it, for the tests of gap-aware commands."""

from __future__ import annotations

import numpy as np

from kinsync.trajectory import Trajectory


def with_gap(traj: Trajectory, t0_s: float, t1_s: float) -> Trajectory:
    """``traj`` without its records strictly between ``t0_s`` and ``t1_s`` (a data gap)."""
    keep = ~((traj.t_s > t0_s) & (traj.t_s < t1_s))

    def cut(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else a[keep]

    return Trajectory(
        t_s=traj.t_s[keep],
        q_body_to_ned=traj.q_body_to_ned[keep],
        lat_lon_h=cut(traj.lat_lon_h),
        pos_ned_m=cut(traj.pos_ned_m),
        origin_lat_lon_h=traj.origin_lat_lon_h,
        vel_ned_m_s=cut(traj.vel_ned_m_s),
    )
