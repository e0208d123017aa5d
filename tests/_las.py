"""Test fixtures written with laspy itself, independently of kinsync's LAS writer."""

from __future__ import annotations

import laspy
import numpy as np


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
