"""Test fixtures written with laspy itself, independently of kinsync's LAS writer."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
from laspy.vlrs.known import GeoKeyDirectoryVlr, GeoKeyEntryStruct


def las_points(
    cols: dict[str, np.ndarray], point_format: int = 6, version: str = "1.4"
) -> laspy.LasData:
    """Points ``x_m, y_m, z_m`` (0.1 mm scale) at standard GPS time ``t_s`` (s).

    The caller sets any other dimension and writes the file.
    """
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.scales = np.array([1e-4, 1e-4, 1e-4])
    header.offsets = np.zeros(3)
    header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD
    las = laspy.LasData(header)
    las.x, las.y, las.z = cols["x_m"], cols["y_m"], cols["z_m"]
    las.gps_time = cols["t_s"] - 1e9
    return las


def add_geo_keys(header: laspy.LasHeader, keys: dict[int, int]) -> None:
    """Declare GeoTIFF keys ``{key id: value}`` (short values) as other software does."""
    entries = []
    for key_id, value in sorted(keys.items()):
        entry = GeoKeyEntryStruct()
        entry.id, entry.tiff_tag_location, entry.count, entry.value_offset = key_id, 0, 1, value
        entries.append(entry)
    directory = GeoKeyDirectoryVlr()
    directory.geo_keys_header.number_of_keys = len(entries)
    directory.geo_keys = entries
    header.vlrs.append(directory)


def geotiff_las(path: Path, keys: dict[int, int], xyz: tuple[float, float, float]) -> Path:
    """A LAS 1.2 file declaring ``keys`` only, as other software writes them."""
    header = laspy.LasHeader(point_format=1, version="1.2")
    add_geo_keys(header, keys)
    header.scales = np.full(3, 1e-4)
    header.offsets = np.round(np.array(xyz))
    las = laspy.LasData(header)
    las.x, las.y, las.z = (np.array([v]) for v in xyz)
    las.write(path)
    return path
