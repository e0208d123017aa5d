"""Control points: independently surveyed targets, the reference of a cloud's validation.

`ControlPoints` holds named positions in ECEF (WGS84); it checks itself on
construction. `kinsync.io.control_points` reads and writes them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import coordinate_array, degree_array, ecef_array, name_tuple
from kinsync.errors import InputError
from kinsync.frames import ecef_to_geodetic, geodetic_to_ecef

__all__ = [
    "ControlPoints",
]


@dataclass(frozen=True, eq=False)
class ControlPoints(ReadOnlyArrays):
    """Named control points in ECEF.

    Parameters
    ----------
    names : sequence of str
        Point names, non-empty and unique.
    pos_ecef_m : array_like, shape (N, 3)
        Surveyed positions, ECEF WGS84 (m), finite.
    source : str
        Where they came from (a file name, for messages).

    Raises
    ------
    InputError
        Empty or duplicated names, a shape that does not match, non-finite values,
        float32 coordinates (too coarse for ECEF) or points not near the Earth's
        surface (local or projected coordinates given as ECEF).
    """

    names: tuple[str, ...]
    pos_ecef_m: FloatArray
    source: str = "<control points>"

    def __post_init__(self) -> None:
        names = tuple(n.strip() for n in name_tuple(self.names, f"{self.source}: names"))
        if not names:
            msg = f"{self.source}: no control points"
            raise InputError(msg)
        empty = [i for i, n in enumerate(names) if not n]
        if empty:
            msg = (
                f"{self.source}: control point at index {empty[0]} (0-based) has an empty "
                "name; name every point"
            )
            raise InputError(msg)
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            msg = f"{self.source}: duplicated control point name(s) {dupes}; names must be unique"
            raise InputError(msg)
        pos = np.array(ecef_array(self.pos_ecef_m, f"{self.source}: pos_ecef_m"))
        if pos.shape != (len(names), 3):
            msg = (
                f"{self.source}: pos_ecef_m must have shape ({len(names)}, 3) to match the "
                f"names, got {pos.shape}"
            )
            raise InputError(msg)
        bad = ~np.all(np.isfinite(pos), axis=1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            msg = f"{self.source}: control point {names[i]!r} has non-finite coordinates"
            raise InputError(msg)
        pos.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "pos_ecef_m", pos)

    @classmethod
    def from_geodetic(
        cls,
        names: tuple[str, ...] | list[str],
        lat_deg: ArrayLike,
        lon_deg: ArrayLike,
        h_m: ArrayLike,
        source: str = "<control points>",
    ) -> ControlPoints:
        """Control points from geodetic WGS84 coordinates (deg, deg, m), each shape (N,).

        Parameters
        ----------
        names : sequence of str, length N
            Point names, non-empty and unique.
        lat_deg, lon_deg : array_like, shape (N,)
            Geodetic latitude in [-90, 90] and longitude (deg, WGS84).
        h_m : array_like, shape (N,)
            Ellipsoidal height (m).
        source : str
            Where they came from (a file name, for messages).

        Returns
        -------
        ControlPoints
            The points converted to ECEF WGS84 (m).

        Raises
        ------
        InputError
            Coordinates not numbers or not finite, a latitude outside [-90, 90],
            coordinates in a float dtype too coarse for 0.1 mm (float32), and
            everything `ControlPoints` refuses (empty or duplicated names, a count of
            names that does not match the coordinates).
        """
        lat = np.atleast_1d(degree_array(lat_deg, f"{source}: lat_deg"))
        lon = np.atleast_1d(degree_array(lon_deg, f"{source}: lon_deg"))
        h = np.atleast_1d(coordinate_array(h_m, f"{source}: h_m"))
        names_ = name_tuple(names, f"{source}: names")
        shapes = {"names": (len(names_),), "lat_deg": lat.shape, "lon_deg": lon.shape}
        shapes["h_m"] = h.shape
        if len(set(shapes.values())) > 1:  # one latitude for two names was broadcast
            given = ", ".join(f"{k} {v}" for k, v in shapes.items())
            msg = f"{source}: give one value per point in each argument, got shapes {given}"
            raise InputError(msg)
        pos = geodetic_to_ecef(lat, lon, h)
        return cls(names=names_, pos_ecef_m=np.atleast_2d(pos), source=source)

    def __len__(self) -> int:
        return len(self.names)

    def lat_lon_h(self) -> FloatArray:
        """Geodetic coordinates ``(lat_deg, lon_deg, h_m)``, shape (N, 3)."""
        return ecef_to_geodetic(self.pos_ecef_m)
