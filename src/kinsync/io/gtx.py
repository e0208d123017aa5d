"""GTX geoid grids (NOAA VDatum layout), the simplest grid PROJ's ``vgridshift`` reads.

Layout: a big-endian header of four doubles (south-west latitude and longitude, latitude
and longitude steps, deg) and two int32 (rows, columns), then the heights as big-endian
float32, row by row from south to north, each row west to east.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from kinsync._typing import ArrayLike
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path

__all__ = ["write_gtx"]


def write_gtx(
    path: Path, lat0_deg: float, lon0_deg: float, step_deg: float, heights_m: ArrayLike
) -> None:
    """Write a geoid grid as GTX, atomically.

    Parameters
    ----------
    path : Path
        Output file.
    lat0_deg, lon0_deg : float
        Latitude and longitude of the south-west node (deg).
    step_deg : float
        Node spacing in latitude and longitude (deg), > 0.
    heights_m : array_like, shape (rows, columns)
        Geoid heights N above the ellipsoid (m), rows from south to north.

    Raises
    ------
    InputError
        A grid that is not 2-D, a spacing that is not positive, or a non-finite height.
    """
    grid = np.asarray(heights_m, dtype=np.float64)
    if grid.ndim != 2 or min(grid.shape) < 2 or not step_deg > 0.0:
        msg = f"{path}: a GTX grid needs (rows, columns) >= 2 and a positive step"
        raise InputError(msg)
    if not np.all(np.isfinite(grid)):
        msg = f"{path}: the geoid heights must be finite"
        raise InputError(msg)
    rows, cols = grid.shape
    with atomic_path(Path(path)) as tmp, tmp.open("wb") as f:
        f.write(struct.pack(">4d2i", lat0_deg, lon0_deg, step_deg, step_deg, rows, cols))
        f.write(grid.astype(">f4").tobytes())
