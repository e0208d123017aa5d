"""Compare a navigation solution with a reference (truth) trajectory.

The truth is interpolated at the solution's epochs inside its span (position by cubic
Hermite when the truth has velocities, else linearly; attitude by slerp; velocity
linearly); epochs outside the truth span, and epochs inside a data gap of the truth
(`kinsync.trajectory_gaps`: a record interval over 10 median intervals, or over an
explicit ``max_gap_s``, where the truth is a guess interpolated across the hole, off by
decimetres and degrees in a turn), are left out and counted. Errors are solution minus truth:

- position in the local NED frame at each solution epoch (m), from the ECEF difference;
- velocity in NED (m/s), when both carry velocities;
- roll, pitch and yaw differences (deg), each wrapped to [-180, 180);
- the misorientation: the rotation vector of ``R_sol · R_truthᵀ`` in NED (rad), the
  quantity whose σ the filter reports (`NavSolution.std_att_rad`).

When the solution is a `NavSolution` the share of epochs with ``|error| <= 3σ`` is given
per state: ``pos_n, pos_e, pos_d, vel_n, vel_e, vel_d`` and ``att_n, att_e, att_d``
(misorientation about N, E, D). A consistent filter gives about 0.997 for Gaussian
errors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import BoolArray, FloatArray
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    geodetic_to_ecef,
    ned_to_ecef,
    quaternion_to_euler_rpy,
    rotation_ned_to_ecef,
)
from kinsync.ins.compare_time import leap_second_offset_text
from kinsync.ins.solution import NavSolution
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import (
    GAP_ADVICE,
    TrajectoryGap,
    gap_index,
    gap_threshold_text,
    max_gap_for,
)

__all__ = ["Comparison", "compare_to_truth"]

Vector3 = tuple[float, float, float]

WITHIN_3SIGMA_KEYS = (
    "pos_n",
    "pos_e",
    "pos_d",
    "vel_n",
    "vel_e",
    "vel_d",
    "att_n",
    "att_e",
    "att_d",
)


@dataclass(frozen=True, eq=False)
class Comparison(ReadOnlyArrays):
    """Errors of a solution against a truth trajectory at common epochs.

    Attributes
    ----------
    n_epochs : int
        Solution epochs compared: inside the truth span and not in one of its gaps.
    t_s : ndarray, shape (n,)
        Their times (s).
    err_pos_ned_m : ndarray, shape (n, 3)
        Position error N, E, D (m), local NED at each epoch.
    err_vel_ned_m_s : ndarray, shape (n, 3) or None
        Velocity error (m/s); None when the solution or the truth has no velocities.
    err_att_deg : ndarray, shape (n, 3)
        Roll, pitch, yaw error (deg), wrapped to [-180, 180).
    err_misorientation_ned_rad : ndarray, shape (n, 3)
        Rotation vector of ``R_sol · R_truthᵀ`` about N, E, D (rad).
    rms_pos_ned_m, max_pos_ned_m : (float, float, float)
        RMS and largest absolute position error per axis (m).
    rms_vel_ned_m_s, max_vel_ned_m_s : (float, float, float) or None
        The same for velocity (m/s).
    rms_att_deg, max_att_deg : (float, float, float)
        The same for roll, pitch, yaw (deg).
    within_3sigma : mapping of str to float, or None
        Share of epochs with ``|error| <= 3σ`` per state (keys in the module
        docstring); None when the solution carries no σ.
    n_outside_truth : int
        Solution epochs left out because they lie outside the truth span.
    n_in_truth_gaps : int
        Solution epochs left out because they lie inside a data gap of the truth.
    truth_gaps : tuple of TrajectoryGap
        The data gaps of the truth that held left-out epochs, in time order.
    truth_gap_threshold_s : float
        Truth record intervals longer than this (s) were data gaps
        (`kinsync.trajectory_gaps.max_gap_for`).
    max_abs_pitch_deg : float
        Largest |pitch| of the truth at the epochs compared (deg). Near 90 deg roll and
        yaw are ill-defined (gimbal lock): their differences can be tens of degrees for
        a misorientation of millidegrees; `rms_misorientation_ned_deg` holds then.
    """

    n_epochs: int
    t_s: FloatArray
    err_pos_ned_m: FloatArray
    err_vel_ned_m_s: FloatArray | None
    err_att_deg: FloatArray
    err_misorientation_ned_rad: FloatArray
    rms_pos_ned_m: Vector3
    max_pos_ned_m: Vector3
    rms_vel_ned_m_s: Vector3 | None
    max_vel_ned_m_s: Vector3 | None
    rms_att_deg: Vector3
    max_att_deg: Vector3
    within_3sigma: Mapping[str, float] | None
    n_outside_truth: int = 0
    n_in_truth_gaps: int = 0
    truth_gaps: tuple[TrajectoryGap, ...] = ()
    truth_gap_threshold_s: float = math.inf
    max_abs_pitch_deg: float = 0.0

    @property
    def rms_misorientation_ned_deg(self) -> Vector3:
        """RMS of the misorientation's rotation vector about N, E, D (deg), any attitude."""
        return _rms(np.degrees(self.err_misorientation_ned_rad))

    def as_document(self) -> dict[str, Any]:
        """The summary as a JSON-ready dict (the ``kinsync ins compare --json`` object)."""
        return {
            "rms_pos_ned_m": list(self.rms_pos_ned_m),
            "rms_vel_ned_m_s": None if self.rms_vel_ned_m_s is None else list(self.rms_vel_ned_m_s),
            "rms_att_deg": list(self.rms_att_deg),
            "max_pos_ned_m": list(self.max_pos_ned_m),
            "max_vel_ned_m_s": None if self.max_vel_ned_m_s is None else list(self.max_vel_ned_m_s),
            "max_att_deg": list(self.max_att_deg),
            "within_3sigma": None if self.within_3sigma is None else dict(self.within_3sigma),
            "n_epochs": self.n_epochs,
            "n_epochs_outside_truth": self.n_outside_truth,
            "n_epochs_in_truth_gaps": self.n_in_truth_gaps,
            "rms_misorientation_ned_deg": list(self.rms_misorientation_ned_deg),
            "max_abs_pitch_deg": self.max_abs_pitch_deg,
            "gap_threshold_s": self.truth_gap_threshold_s,
            "truth_gaps": [
                {"t_start_s": g.t_start_s, "t_end_s": g.t_end_s} for g in self.truth_gaps
            ],
        }


def _vec(values: FloatArray) -> Vector3:
    return (float(values[0]), float(values[1]), float(values[2]))


def _rms(err: FloatArray) -> Vector3:
    return _vec(np.sqrt(np.mean(err**2, axis=0)))


def _max(err: FloatArray) -> Vector3:
    return _vec(np.max(np.abs(err), axis=0))


def _wrap_deg(angle_deg: FloatArray) -> FloatArray:
    out: FloatArray = (angle_deg + 180.0) % 360.0 - 180.0
    return out


def _epochs_to_compare(
    traj: Trajectory, truth: Trajectory, max_gap_s: float
) -> tuple[BoolArray, int, tuple[TrajectoryGap, ...]]:
    """The solution epochs to compare: those the truth can be read at.

    Returns them (mask), the count outside the truth span and the truth's gaps (record
    intervals longer than ``max_gap_s``) that hold the others; `InputError` when none
    is left.
    """
    keep = truth.contains(traj.t_s, max_gap_s=max_gap_s)
    in_span = truth.contains(traj.t_s, max_gap_s=math.inf)
    in_gaps = in_span & ~keep
    gaps = truth.gaps(max_gap_s)
    hit = tuple(gaps[int(k)] for k in np.unique(gap_index(traj.t_s[in_gaps], gaps)))
    if np.any(keep):
        return keep, int(np.count_nonzero(~in_span)), hit
    spans = (
        f"the solution spans [{traj.t_start_s!r}, {traj.t_end_s!r}] s, the truth "
        f"[{truth.t_start_s!r}, {truth.t_end_s!r}] s"
    )
    if np.any(in_gaps):
        named = "; ".join(g.describe() for g in hit[:3])
        msg = (
            f"no common times: {spans}, and the {int(np.count_nonzero(in_gaps))} solution "
            f"epoch(s) inside it lie in its data gaps ({named}), "
            f"{gap_threshold_text(max_gap_s)}, where the truth is not interpolated: "
            f"{GAP_ADVICE}"
        )
    else:
        msg = f"no common times: {spans}; are both on the same time scale?"
    raise InputError(msg)


def compare_to_truth(
    solution: NavSolution | Trajectory, truth: Trajectory, *, max_gap_s: float | None = None
) -> Comparison:
    """Compare a solution with a truth trajectory at the solution's epochs.

    Parameters
    ----------
    solution : NavSolution or Trajectory
        The estimate (geodetic or local NED trajectory, or a filter solution with σ).
    truth : Trajectory
        Reference trajectory (geodetic or local NED; velocities optional).
    max_gap_s : float, optional
        Longest truth record interval (s) interpolated across; epochs inside a longer
        one (a data gap) are left out. Default `kinsync.trajectory_gaps.GAP_FACTOR`
        median record intervals.

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        No solution epoch lies inside the truth span (naming both spans) outside its
        data gaps; a ``max_gap_s`` that is not a positive number; a solution that
        matches the truth far better 10 to 18 whole seconds apart (UTC against GPS
        time: `kinsync.ins.compare_time`).
    """
    limit_s = max_gap_for(truth.t_s, max_gap_s)
    sigma: tuple[FloatArray, FloatArray, FloatArray] | None = None
    if isinstance(solution, NavSolution):
        sigma = (solution.std_pos_ned_m, solution.std_vel_ned_m_s, solution.std_att_rad)
        traj = solution.to_trajectory()
    else:
        traj = solution
    keep, n_outside, truth_gaps = _epochs_to_compare(traj, truth, limit_s)
    n = int(np.count_nonzero(keep))
    t = traj.t_s[keep]
    q_sol = traj.q_body_to_ned[keep]
    ref = truth.interpolate(t, max_gap_s=limit_s)
    if traj.lat_lon_h is not None:
        lat, lon, h = traj.lat_lon_h[keep].T
        pos_sol_ecef = geodetic_to_ecef(lat, lon, h)
    else:
        assert traj.pos_ned_m is not None
        assert traj.origin_lat_lon_h is not None
        pos_sol_ecef = ned_to_ecef(traj.pos_ned_m[keep], *traj.origin_lat_lon_h)
        lat, lon = ecef_to_geodetic(pos_sol_ecef)[:, :2].T
    offset = leap_second_offset_text(t, pos_sol_ecef, truth, limit_s)
    if offset:
        raise InputError(offset)
    R_ned_to_ecef = rotation_ned_to_ecef(lat, lon)
    err_pos = np.einsum("nji,nj->ni", R_ned_to_ecef, pos_sol_ecef - ref.pos_ecef_m())

    err_vel: FloatArray | None = None
    if traj.vel_ned_m_s is not None and truth.vel_ned_m_s is not None:
        v_ref = np.column_stack(
            [np.interp(t, truth.t_s, truth.vel_ned_m_s[:, i]) for i in range(3)]
        )
        err_vel = traj.vel_ned_m_s[keep] - v_ref

    rpy_sol = np.degrees(quaternion_to_euler_rpy(q_sol))
    rpy_ref = np.degrees(quaternion_to_euler_rpy(ref.q_body_to_ned))
    err_att = _wrap_deg(rpy_sol - rpy_ref)
    r_sol = Rotation.from_quat(q_sol[:, [1, 2, 3, 0]])
    r_ref = Rotation.from_quat(ref.q_body_to_ned[:, [1, 2, 3, 0]])
    err_rot: FloatArray = (r_sol * r_ref.inv()).as_rotvec()

    within: dict[str, float] | None = None
    if sigma is not None:
        std_pos, std_vel, std_att = (s[keep] for s in sigma)
        within = {}
        blocks: list[tuple[str, FloatArray | None, FloatArray]] = [
            ("pos", err_pos, std_pos),
            ("vel", err_vel, std_vel),
            ("att", err_rot, std_att),
        ]
        for name, err, std in blocks:
            if err is None:
                continue
            share = np.mean(np.abs(err) <= 3.0 * std, axis=0)
            for axis, value in zip("ned", share.tolist(), strict=True):
                within[f"{name}_{axis}"] = float(value)
    return Comparison(
        n_epochs=n,
        t_s=t,
        err_pos_ned_m=err_pos,
        err_vel_ned_m_s=err_vel,
        err_att_deg=err_att,
        err_misorientation_ned_rad=err_rot,
        rms_pos_ned_m=_rms(err_pos),
        max_pos_ned_m=_max(err_pos),
        rms_vel_ned_m_s=None if err_vel is None else _rms(err_vel),
        max_vel_ned_m_s=None if err_vel is None else _max(err_vel),
        rms_att_deg=_rms(err_att),
        max_att_deg=_max(err_att),
        within_3sigma=within,
        n_outside_truth=n_outside,
        n_in_truth_gaps=traj.t_s.size - n - n_outside,
        truth_gaps=truth_gaps,
        truth_gap_threshold_s=limit_s,
        max_abs_pitch_deg=float(np.max(np.abs(rpy_ref[:, 1]))) if n else 0.0,
    )
