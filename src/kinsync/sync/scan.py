"""What Method B works on: a profile scan without times, and sync points (SPEC section 4).

`ProfileScan` holds the returns of a 2D profile scanner in acquisition order (profile
number, mirror angle, range, intensity); `SyncPoints` the named targets of known WGS84
position. Both check themselves on construction. `kinsync.io.profile_scan` reads and
writes them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import geodetic_array, name_tuple
from kinsync.errors import InputError
from kinsync.frames import geodetic_to_ecef
from kinsync.mount import MAX_PROFILE_ANGLE_RAD

__all__ = [
    "MAX_PROFILE_NUMBER",
    "PROFILE_SCANNER_REACH_M",
    "SCAN_COLUMNS",
    "SYNC_POINT_COLUMNS",
    "ProfileScan",
    "SyncPoints",
]

SCAN_COLUMNS = ("profile", "angle_rad", "range_m", "intensity")


SYNC_POINT_COLUMNS = ("name", "lat_deg", "lon_deg", "h_m")


def _index_text(row: int) -> str:
    """An array index, said to be one (a reader passes the file's own words instead)."""
    return f"index {row} (0-based)"


MAX_PROFILE_NUMBER = 1e12
"""Largest profile number accepted: 31 years of profiles at 1 kHz (a larger value is a
damaged column, and its product with the period would lose the profile's time)."""


PROFILE_SCANNER_REACH_M = 2000.0
"""Range (m) beyond any 2D profile scanner's reach: a scan whose median range is longer
probably has its ranges in millimetres."""


def long_range_note(n_long: int, n: int) -> str:
    """Advice when most ranges lie beyond `PROFILE_SCANNER_REACH_M`, else ``""``.

    Parameters
    ----------
    n_long : int
        Number of returns whose range exceeds `PROFILE_SCANNER_REACH_M`.
    n : int
        Number of returns.

    Returns
    -------
    str
        ``"the median range is beyond 2000 m ...: are the ranges in millimetres? ..."``
        when more than half of the ``n`` ranges are that long, else ``""``.
    """
    if n == 0 or 2 * n_long <= n:
        return ""
    return (
        f"{n_long:,} of {n:,} ranges (the median too) are beyond "
        f"{PROFILE_SCANNER_REACH_M:.0f} m, further than a profile scanner reaches: are the "
        "ranges in millimetres? range_m is in metres"
    )


def _checked_profile_numbers(
    profile: ArrayLike, source: str, where: Callable[[int], str] | None = None
) -> IntArray:
    """Profile numbers as int64: whole, >= 0 and never decreasing.

    Parameters
    ----------
    profile : array_like, shape (N,)
        Profile number of each return.
    source : str
        Name used in messages (file path).
    where : callable of int to str, optional
        Names ``profile[i]`` in messages as the reader's file counts it (``line 7``,
        ``row 6 of 9``); default its 0-based index, said to be one.

    Raises
    ------
    InputError
        Naming the first row that is not finite, not whole, negative or smaller than
        the row before.
    """
    name = _index_text if where is None else where
    p = np.asarray(profile, dtype=np.float64)
    with np.errstate(invalid="ignore"):  # NaN and inf are reported below, not warned
        bad = ~np.isfinite(p) | (p != np.round(p)) | (p < 0) | (p > MAX_PROFILE_NUMBER)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = (
            f"{source}: {name(row)}, column 'profile': "
            f"{float(p[row])!r} is not a profile number (a whole number from 0 to "
            f"{MAX_PROFILE_NUMBER:.0e})"
        )
        raise InputError(msg)
    down = np.diff(p) < 0
    if np.any(down):
        row = int(np.flatnonzero(down)[0]) + 1
        msg = (
            f"{source}: {name(row)}, column 'profile': profile "
            f"number {int(p[row])} after {int(p[row - 1])}; profile numbers must not decrease "
            "(returns in acquisition order): sort the scan by profile, keeping the order "
            "within each profile"
        )
        raise InputError(msg)
    return p.astype(np.int64)


def _finite_column(values: ArrayLike, name: str, n: int, source: str) -> FloatArray:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (n,):
        msg = f"{source}: column {name!r} has shape {arr.shape}, expected ({n},) like 'profile'"
        raise InputError(msg)
    bad = ~np.isfinite(arr)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = f"{source}: {_index_text(row)}, column {name!r}: {arr[row]!r} is not a finite number"
        raise InputError(msg)
    out = np.array(arr, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class ProfileScan(ReadOnlyArrays):
    """Returns of a 2D profile scanner, without times (SPEC section 4).

    Attributes
    ----------
    profile : ndarray of int64, shape (N,)
        Profile number n of each return, >= 0, never decreasing.
    angle_rad : ndarray, shape (N,)
        Mirror angle phi from nadir, positive towards the scanner's +Y (rad), within
        +-`~kinsync.mount.MAX_PROFILE_ANGLE_RAD` (one turn; more is degrees).
    range_m : ndarray, shape (N,)
        Range (m), >= 0.
    intensity : ndarray, shape (N,)
        Return intensity (unit of the scanner).
    source : str
        Where the scan came from (file path), for messages.
    """

    profile: IntArray
    angle_rad: FloatArray
    range_m: FloatArray
    intensity: FloatArray
    source: str = "<scan>"

    def __post_init__(self) -> None:
        prof = _checked_profile_numbers(self.profile, self.source)
        n = prof.size
        if prof.ndim != 1 or n == 0:
            msg = f"{self.source}: the scan has no returns; expected columns {list(SCAN_COLUMNS)}"
            raise InputError(msg)
        prof.setflags(write=False)
        object.__setattr__(self, "profile", prof)
        for name in ("angle_rad", "range_m", "intensity"):
            object.__setattr__(
                self, name, _finite_column(getattr(self, name), name, n, self.source)
            )
        turned = np.abs(self.angle_rad) > MAX_PROFILE_ANGLE_RAD
        if np.any(turned):
            row = int(np.flatnonzero(turned)[0])
            msg = (
                f"{self.source}: {_index_text(row)}, column 'angle_rad': "
                f"{self.angle_rad[row]!r} is beyond one turn (+-2 pi rad); give the mirror "
                "angles in radians (degrees given as radians?)"
            )
            raise InputError(msg)
        neg = self.range_m < 0
        if np.any(neg):
            row = int(np.flatnonzero(neg)[0])
            msg = (
                f"{self.source}: {_index_text(row)}, column 'range_m': negative range "
                f"{self.range_m[row]}"
            )
            raise InputError(msg)

    def __len__(self) -> int:
        return int(self.profile.size)

    @staticmethod
    def checked_profile_numbers(
        profile: ArrayLike, source: str, where: Callable[[int], str] | None = None
    ) -> IntArray:
        """Profile numbers as int64: whole, >= 0 and never decreasing.

        For readers and pipelines that check a column (or a chunk of it) before the
        scan is built; parameters and errors as in the module's
        ``_checked_profile_numbers``: ``source`` names the file, ``where(i)`` the
        place of ``profile[i]`` in it (``line 7``, ``row 6 of 9``).

        Parameters
        ----------
        profile : array_like, shape (N,)
            Profile number of each return, in acquisition order.
        source : str
            Name used in messages (file path).
        where : callable of int to str, optional
            Names ``profile[i]`` in messages as the reader's file counts it (``line
            7``, ``row 6 of 9``); default its 0-based index, said to be one.

        Returns
        -------
        ndarray of int64, shape (N,)
            The profile numbers.

        Raises
        ------
        InputError
            Naming the first row that is not finite, not whole, negative, beyond
            `MAX_PROFILE_NUMBER` or smaller than the row before.
        """
        return _checked_profile_numbers(profile, source, where)

    @property
    def n_profiles(self) -> int:
        """Profiles spanned, ``last profile number + 1`` (profiles without returns count)."""
        return int(self.profile[-1]) + 1


@dataclass(frozen=True, eq=False)
class SyncPoints(ReadOnlyArrays):
    """Named targets with known WGS84 coordinates (sync points or control points).

    Attributes
    ----------
    names : tuple of str
        Unique, non-empty names.
    lat_lon_h : ndarray, shape (K, 3)
        Latitude (deg), longitude (deg), ellipsoidal height (m) of each target centre;
        a float dtype too coarse for 0.1 mm (float32) is refused
        (`kinsync._validate.geodetic_array`).
    source : str
        Where they came from (file path), for messages.
    lines : tuple of int or None
        The line of ``source`` each point was read from, for messages (`label`); None
        when the points were not read from a text file.
    """

    names: tuple[str, ...]
    lat_lon_h: FloatArray
    source: str = "<sync points>"
    lines: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        names = name_tuple(self.names, f"{self.source}: names")
        llh = geodetic_array(self.lat_lon_h, f"{self.source}: lat_lon_h")
        if llh.ndim != 2 or llh.shape[1] != 3 or llh.shape[0] != len(names):
            msg = (
                f"{self.source}: expected one (lat_deg, lon_deg, h_m) row per name "
                f"({len(names)} names), got shape {llh.shape}"
            )
            raise InputError(msg)
        if not names:
            msg = f"{self.source}: no points; expected rows of {','.join(SYNC_POINT_COLUMNS)}"
            raise InputError(msg)
        for i, name in enumerate(names):
            if not name.strip():
                msg = f"{self.source}: point at index {i} (0-based) has an empty name"
                raise InputError(msg)
            if names.count(name) > 1:
                msg = f"{self.source}: name {name!r} appears more than once; names must be unique"
                raise InputError(msg)
        bad = ~np.all(np.isfinite(llh), axis=1) | (np.abs(llh[:, 0]) > 90.0)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            msg = (
                f"{self.source}: point {names[i]!r}: lat/lon/h {llh[i].tolist()} is not a "
                "finite WGS84 position with latitude in [-90, 90]"
            )
            raise InputError(msg)
        if self.lines is not None and len(self.lines) != len(names):
            msg = f"{self.source}: {len(self.lines)} line numbers for {len(names)} points"
            raise InputError(msg)
        llh = llh.copy()
        llh.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "lat_lon_h", llh)
        if self.lines is not None:
            object.__setattr__(self, "lines", tuple(int(n) for n in self.lines))

    def __len__(self) -> int:
        return len(self.names)

    def label(self, i: int) -> str:
        """Point i named for messages: ``'S1' (line 2)``, or ``'S1'`` without `lines`.

        Parameters
        ----------
        i : int
            Index of the point (0-based).

        Returns
        -------
        str
            The quoted name, with the line of `source` it was read from when known.
        """
        line = "" if self.lines is None else f" (line {self.lines[i]})"
        return f"{self.names[i]!r}{line}"

    def pos_ecef_m(self) -> FloatArray:
        """Target centres in ECEF (m), shape (K, 3)."""
        return geodetic_to_ecef(self.lat_lon_h[:, 0], self.lat_lon_h[:, 1], self.lat_lon_h[:, 2])
