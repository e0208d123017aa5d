"""Is a trajectory the one a cloud was scanned from? (SPEC section 7).

Validation reads the vehicle's state at each target's scan time from the trajectory;
the target's position relative to the vehicle enters the time-error regressor (the
along-track velocity ``v + omega x r`` of the target carried with the vehicle frame).
A trajectory of another place or height makes ``r`` hundreds of metres or kilometres
long: the rotation term ``omega x r`` of the vehicle's roll, pitch and yaw noise then
swamps the speed, and the time error collapses to a "not significant" zero. Two checks
refuse such a trajectory:

- `check_visit_ranges`: at each visit's time the scanner-to-target range (trajectory
  to control point) is at most `MAX_SCAN_RANGE_M`: no kinematic laser scanner measures
  farther (airborne ranges are 1-5 km).
- `check_cloud_view`: for a sample of the cloud's points, scanned from more than
  `FAR_RANGE_M` away, the lines of sight from the trajectory must not all lie within
  `NARROW_VIEW_DEG` of straight down (or up): a laser scanner that far above its
  points sweeps a field of ±10° or more about nadir; a strip that narrow is a
  ground-level cloud seen from a trajectory that is too high (or too low).
"""

from __future__ import annotations

import math

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic, rotation_ned_to_ecef
from kinsync.trajectory import Trajectory
from kinsync.validation.differences import ControlPointDifference

__all__ = [
    "FAR_RANGE_M",
    "MAX_SCAN_RANGE_M",
    "NARROW_VIEW_DEG",
    "check_cloud_view",
    "check_visit_ranges",
]

MAX_SCAN_RANGE_M = 20_000.0
"""Longest scanner-to-target range (m) of any kinematic laser scanner, with margin."""
FAR_RANGE_M = 100.0
"""Median scanner-to-point range (m) beyond which `check_cloud_view` applies."""
NARROW_VIEW_DEG = 3.0
"""Half-angle (deg) about nadir/zenith that a far scanner's lines of sight exceed."""
_MIN_SAMPLE = 20


def _far(distance_m: float) -> str:
    """A distance in words: km beyond 10 km, else m."""
    if distance_m >= 10_000.0:
        return f"{distance_m / 1000:,.0f} km"
    return f"{distance_m:,.1f} m"


def check_visit_ranges(differences: tuple[ControlPointDifference, ...], trajectory: str) -> None:
    """Refuse a scanner-to-target range beyond `MAX_SCAN_RANGE_M` at any visit.

    Parameters
    ----------
    differences : tuple of ControlPointDifference
        The visits, each with the target's position relative to the vehicle
        (``lateral_m``, ``forward_m``, ``up_m``, m) at its scan time.
    trajectory : str
        The trajectory's name, for the message.

    Raises
    ------
    InputError
        The farthest visit lies beyond `MAX_SCAN_RANGE_M`: named with its time and
        range.
    """
    if not differences:
        return
    ranges_m = [math.hypot(d.lateral_m, d.forward_m, d.up_m) for d in differences]
    i = int(np.argmax(ranges_m))
    if ranges_m[i] <= MAX_SCAN_RANGE_M:
        return
    d = differences[i]
    msg = (
        f"{trajectory}: at the time control point {d.observation.name} was scanned "
        f"(t_s {d.observation.t_s!r}) the trajectory lies {_far(ranges_m[i])} from it: "
        "no kinematic laser scanner measures that far (at most "
        f"{MAX_SCAN_RANGE_M / 1000:g} km is accepted; airborne ranges are 1-5 km): this "
        "trajectory does not belong to the cloud (another survey, latitude and longitude "
        "swapped, radians, heights in mm?); give the trajectory the cloud was "
        "georeferenced with"
    )
    raise InputError(msg)


def check_cloud_view(
    trajectory: Trajectory, pos_ecef_m: FloatArray, t_s: FloatArray, name: str
) -> None:
    """Refuse a trajectory far above (or below) a cloud that it sees only at nadir.

    Parameters
    ----------
    trajectory : Trajectory
        The trajectory the validation reads.
    pos_ecef_m : ndarray, shape (N, 3)
        A sample of the cloud's points, ECEF WGS84 (m).
    t_s : ndarray, shape (N,)
        Their scan times (s, the trajectory's time scale); those outside the
        trajectory's span or in its data gaps are left out.
    name : str
        The trajectory's name, for the message.

    Raises
    ------
    InputError
        The median scanner-to-point range exceeds `FAR_RANGE_M` while every sampled
        line of sight lies within `NARROW_VIEW_DEG` of straight down or up.
    """
    sample = trajectory.interpolate(t_s, position="linear", mask_outside=True)
    inside = np.asarray(sample.inside, dtype=bool)
    if int(inside.sum()) < _MIN_SAMPLE:
        return
    vehicle = sample.pos_ecef_m()[inside]
    points = np.asarray(pos_ecef_m, dtype=np.float64)[inside]
    llh = ecef_to_geodetic(vehicle)
    sight_m = points - vehicle
    down_ecef = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])[:, :, 2]  # each vehicle's down
    up = -np.einsum("ij,ij->i", down_ecef, sight_m)
    range_m = np.linalg.norm(sight_m, axis=1)
    ok = range_m > 0.0
    if int(ok.sum()) < _MIN_SAMPLE:
        return
    median_m = float(np.median(range_m[ok]))
    off_vertical = np.degrees(np.arccos(np.clip(np.abs(up[ok]) / range_m[ok], 0.0, 1.0)))
    widest_deg = float(np.max(off_vertical))
    if median_m <= FAR_RANGE_M or widest_deg >= NARROW_VIEW_DEG:
        return
    where = "above" if float(np.median(up[ok])) < 0.0 else "below"
    msg = (
        f"{name}: at the times the cloud's points were scanned the trajectory lies "
        f"{_far(median_m)} (median) {where} them, and every point lies within "
        f"{widest_deg:.1f}° of straight {'down' if where == 'above' else 'up'} from it: "
        f"a scanner more than {FAR_RANGE_M:g} m from its points sweeps far wider (airborne "
        f"scanners ±10° or more; under {NARROW_VIEW_DEG:g}° is refused): this trajectory "
        "does not belong to the cloud (a height offset, heights in mm or feet, another "
        "survey?); give the trajectory the cloud was georeferenced with (for an "
        "airborne cloud cut to a narrow strip under the flight line, the uncut strip)"
    )
    raise InputError(msg)
