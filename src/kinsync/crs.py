"""Coordinate reference systems: transformations between ECEF and a user's CRS (pyproj).

Both directions take any pyproj user input (``EPSG:32619``, WKT, PROJ strings) and
return a function over ``(n, 3)`` arrays (axis order easting/longitude first), or
None when the CRS is ECEF itself (EPSG:4978), so that callers skip the identity.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
import pyproj

from kinsync._typing import FloatArray
from kinsync.errors import InputError

__all__ = ["crs_to_ecef_transformer", "ecef_to_crs_transformer"]


@lru_cache(maxsize=8)
def ecef_to_crs_transformer(crs: str) -> Callable[[FloatArray], FloatArray] | None:
    """ECEF -> ``crs`` (axis order easting/longitude first), or None for ECEF itself."""
    try:
        target = pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as err:
        msg = f"--crs {crs!r}: unknown coordinate reference system ({err}); e.g. EPSG:4978"
        raise InputError(msg) from err
    if target == pyproj.CRS.from_epsg(4978):
        return None
    transformer = pyproj.Transformer.from_crs(pyproj.CRS.from_epsg(4978), target, always_xy=True)

    def apply(pos_ecef_m: FloatArray) -> FloatArray:
        x, y, z = transformer.transform(pos_ecef_m[:, 0], pos_ecef_m[:, 1], pos_ecef_m[:, 2])
        return np.column_stack([x, y, z]).astype(np.float64)

    return apply


@lru_cache(maxsize=8)
def crs_to_ecef_transformer(crs_text: str) -> Callable[[FloatArray], FloatArray] | None:
    """Cloud CRS -> ECEF (axis order easting/longitude first), None for ECEF itself."""
    try:
        crs = pyproj.CRS.from_user_input(crs_text)
    except pyproj.exceptions.CRSError as err:
        msg = f"--crs {crs_text!r}: unknown coordinate reference system ({err}); e.g. EPSG:4978"
        raise InputError(msg) from err
    if crs.equals(pyproj.CRS.from_epsg(4978), ignore_axis_order=True):
        return None
    try:
        transformer = pyproj.Transformer.from_crs(crs, pyproj.CRS.from_epsg(4978), always_xy=True)
    except pyproj.exceptions.ProjError as err:
        msg = f"--crs {crs_text!r}: no transformation to ECEF (EPSG:4978) ({err})"
        raise InputError(msg) from err

    def apply(xyz: FloatArray) -> FloatArray:
        x, y, z = transformer.transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        out = np.column_stack([x, y, z]).astype(np.float64)
        if not np.all(np.isfinite(out)):
            row = int(np.flatnonzero(~np.all(np.isfinite(out), axis=1))[0])
            msg = (
                f"--crs {crs_text!r}: point {xyz[row].tolist()} does not convert to ECEF; "
                "is the cloud in this CRS?"
            )
            raise InputError(msg)
        return out

    return apply
