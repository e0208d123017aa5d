"""2D profile scanner points georeferenced (SPEC sections 4 and 5).

Profile scanners give a range and a mirror angle instead of x, y, z:
`profile_points_to_scanner` puts them in the scanner frame with the mount's fixed
azimuth (``x_s = R_2d^s · x_2d``) and `georeference_profile` georeferences them with
the kernel of `kinsync.georef.kernel`. Both take ``range_m=`` and ``angle_rad=`` by
name only, as `Mount.profile_to_scanner` does: two float arrays given in the wrong
order would give wrong points without an error whenever every range is under 2 pi m.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync.errors import InputError
from kinsync.georef.kernel import PositionMethod, georeference, point_value_error
from kinsync.georef.trajectory import GeorefTrajectory
from kinsync.mount import MAX_PROFILE_ANGLE_RAD, Mount

__all__ = [
    "PROFILE_COLUMNS",
    "georeference_profile",
    "profile_points_to_scanner",
]

PROFILE_COLUMNS = ("range_m", "angle_rad")
"""Columns of a profile-point table besides the time: range (m) and mirror angle (rad)."""


def profile_points_to_scanner(
    *, range_m: ArrayLike, angle_rad: ArrayLike, mount: Mount, what: str = "georeference"
) -> FloatArray:
    """2D profile points (range, mirror angle) in the scanner frame, validated.

    Every argument is keyword-only (``range_m=``, ``angle_rad=``, ``mount=``), so
    the ranges and angles cannot be swapped by position.

    ``Rz(azimuth) · (0, r sin phi, r cos phi)`` (`Mount.profile_to_scanner`, SPEC
    sections 4 and 5) with the mount's ``[profiler] azimuth_deg``.

    Parameters
    ----------
    range_m : array_like, shape (N,)
        Ranges (m), finite and >= 0.
    angle_rad : array_like, shape (N,)
        Mirror angles phi from the scanner's Z axis, positive towards +Y (rad), finite.
    mount : Mount
        Must have ``profiler_azimuth_deg`` (the ``[profiler]`` table).
    what : str
        Prefix of error messages.

    Returns
    -------
    ndarray, shape (N, 3)
        Points in the scanner frame (m).

    Raises
    ------
    InputError
        No profiler azimuth in the mount, mismatched shapes, non-finite values, an
        angle beyond one turn (`kinsync.mount.MAX_PROFILE_ANGLE_RAD`), a negative range
        (each naming the first bad index).
    """
    if mount.profiler_azimuth_deg is None:
        msg = (
            f"{what}: profile points need the profiler azimuth: add [profiler] azimuth_deg "
            "to the mount (or pass --profiler-azimuth-deg)"
        )
        raise InputError(msg)
    try:
        r = np.ascontiguousarray(range_m, dtype=np.float64)
        phi = np.ascontiguousarray(angle_rad, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"{what}: ranges and angles must be numbers ({err})"
        raise InputError(msg) from err
    if r.ndim != 1 or phi.shape != r.shape:
        msg = f"{what}: range_m and angle_rad must be 1-D of one length, got {r.shape}, {phi.shape}"
        raise InputError(msg)
    bad = ~(np.isfinite(r) & np.isfinite(phi))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        field = "range_m" if not np.isfinite(r[i]) else "angle_rad"
        value = float(r[i]) if field == "range_m" else float(phi[i])
        problem = f"{value!r} is not finite (range_m {float(r[i])!r}, angle_rad {float(phi[i])!r})"
        raise point_value_error(what, bad, field, problem, "drop or fix them", r.size)
    wide = np.abs(phi) > MAX_PROFILE_ANGLE_RAD
    if np.any(wide):
        i = int(np.flatnonzero(wide)[0])
        problem = f"angle {float(phi[i])!r} rad is beyond one turn (+-2 pi)"
        raise point_value_error(
            what, wide, "angle_rad", problem, "mirror angles are radians within one turn", r.size
        )
    negative = r < 0.0
    if np.any(negative):
        i = int(np.flatnonzero(negative)[0])
        problem = f"range {float(r[i])!r} is negative"
        raise point_value_error(what, negative, "range_m", problem, "a range is >= 0", r.size)
    return mount.profile_to_scanner(angle_rad=phi, range_m=r)


def georeference_profile(
    t_s: ArrayLike,
    *,
    range_m: ArrayLike,
    angle_rad: ArrayLike,
    traj: GeorefTrajectory,
    mount: Mount,
    position: PositionMethod = "auto",
) -> tuple[FloatArray, BoolArray]:
    """Georeference 2D profile points (SPEC section 5 with ``R_2d^s``) into ECEF.

    Every argument but ``t_s`` is keyword-only, so the ranges and angles cannot be
    swapped by position.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Point times (s) on the scanner's time scale.
    range_m, angle_rad : array_like, shape (N,)
        Range (m) and mirror angle (rad), see `profile_points_to_scanner`.
    traj : GeorefTrajectory
        Precomputed trajectory, corrected for ``mount.latency_s``.
    mount : Mount
        Lever arm, boresight, latency and ``profiler_azimuth_deg`` (required).
    position : {"auto", "linear", "hermite"}
        Position interpolation (see `georeference`).

    Returns
    -------
    pos_ecef_m : ndarray, shape (N, 3)
        Georeferenced points, ECEF (m); NaN where outside the trajectory's span.
    inside : ndarray of bool, shape (N,)
        True where the point time lies within the trajectory's span.

    Raises
    ------
    InputError
        As `profile_points_to_scanner` and `georeference`.
    """
    xyz = profile_points_to_scanner(range_m=range_m, angle_rad=angle_rad, mount=mount)
    return georeference(t_s, xyz, traj, mount, position=position)
