"""Result of `kinsync.ins.filter.run_ins`: the solutions, the GNSS innovations and status."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray, IntArray
from kinsync.ins._ekf import N_ERR
from kinsync.ins.solution import NavSolution

__all__ = ["InsResult"]


@dataclass(frozen=True, eq=False)
class InsResult(ReadOnlyArrays):
    """Forward (and optionally smoothed) INS/GNSS solution.

    Attributes
    ----------
    forward : NavSolution
        Forward-filter solution at the IMU epochs from the initial epoch on.
    smoothed : NavSolution or None
        RTS-smoothed solution on the same epochs, when requested.
    innovations_pos_ned_m : ndarray, shape (m_in, 3)
        GNSS minus predicted antenna position (N, E, D, m) before the update, one row
        per GNSS epoch inside the IMU span; NaN rows for epochs rejected by the gate.
    gnss_rejected_t_s : ndarray, shape (r,)
        Times of the GNSS epochs rejected by the χ² gate (s).
    innovations_t_s : ndarray, shape (m_in,)
        GNSS times of the innovation rows (s).
    innovations_vel_ned_m_s : ndarray, shape (m_in, 3)
        GNSS minus predicted antenna velocity (m/s); NaN where velocities were not
        used or the epoch was rejected.
    innovation_std_pos_ned_m : ndarray, shape (m_in, 3)
        Predicted standard deviation ``sqrt(diag S)`` of each position innovation (m);
        NaN for rejected epochs.
    gnss_status : ndarray of int, shape (m,)
        `kinsync.ins.filter.GnssStatus` of every GNSS epoch of the input.
    warnings : tuple of str
        What the checks of `kinsync.ins.filter.run_ins` found doubtful without refusing the run (the
        input checks' warnings, then the χ² gate's), each naming its input; empty when
        all is well.
    error_states : int
        Size of the error state the filter ran with: 21, or 27 with scale factors
        (`InsConfig.models_scale_factors`), plus one after a levelled standstill
        (22 or 28, `kinsync.ins.standstill`).
    rejected_innovations_pos_ned_m : ndarray, shape (r, 3)
        GNSS minus predicted antenna position (N, E, D, m) of each epoch the χ² gate
        rejected, in the order of ``gnss_rejected_t_s`` (they did not update the filter).
    rejected_innovation_std_pos_ned_m : ndarray, shape (r, 3)
        Predicted standard deviation of those innovations (m).
    """

    forward: NavSolution
    smoothed: NavSolution | None
    innovations_pos_ned_m: FloatArray
    gnss_rejected_t_s: FloatArray
    innovations_t_s: FloatArray = field(default_factory=lambda: np.empty(0))
    innovations_vel_ned_m_s: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    innovation_std_pos_ned_m: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    gnss_status: IntArray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    warnings: tuple[str, ...] = ()
    error_states: int = N_ERR
    rejected_innovations_pos_ned_m: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    rejected_innovation_std_pos_ned_m: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
