"""Trajectory lines for a quick look: GeoJSON and KML, WGS 84 longitude/latitude.

Both files hold one line (a GeoJSON ``LineString`` Feature, RFC 7946, or a
``MultiLineString`` cut at the antimeridian as its section 3.1.9 asks; a KML 2.2
``Placemark`` with a ``LineString``) through the vertices given, in WGS 84 longitude
and latitude (degrees, 9 decimals: 0.1 mm). GeoJSON carries the ellipsoidal height as
the third coordinate; KML draws the line on the ground (``clampToGround``: KML heights
are above the geoid, which an ellipsoidal height is not). `decimate` picks a bounded
number of vertices spread evenly over the records, first and last included. The files
are written atomically.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path

__all__ = ["antimeridian_parts", "decimate", "write_geojson_line", "write_kml_line"]


def decimate(n: int, max_vertices: int) -> np.ndarray[Any, np.dtype[np.intp]]:
    """Indices of at most ``max_vertices`` of ``n`` records, evenly spread, ends kept.

    Raises
    ------
    InputError
        ``max_vertices`` below 2 (a line needs two vertices).
    """
    if max_vertices < 2:
        msg = f"--max-vertices must be >= 2 (a line has two ends), got {max_vertices}"
        raise InputError(msg)
    if n <= max_vertices:
        return np.arange(n, dtype=np.intp)
    return np.unique(np.round(np.linspace(0, n - 1, max_vertices)).astype(np.intp))


def _check(lon_deg: FloatArray, lat_deg: FloatArray) -> None:
    if len(lon_deg) != len(lat_deg) or len(lon_deg) < 2:
        msg = f"a line needs >= 2 vertices of longitude and latitude, got {len(lon_deg)}"
        raise InputError(msg)
    if not (np.isfinite(lon_deg).all() and np.isfinite(lat_deg).all()):
        msg = "a line's longitudes and latitudes must be finite"
        raise InputError(msg)


def write_geojson_line(
    path: Path,
    lon_deg: FloatArray,
    lat_deg: FloatArray,
    h_m: FloatArray,
    properties: Mapping[str, Any],
) -> None:
    """Write a GeoJSON FeatureCollection with one LineString Feature (RFC 7946).

    A line that crosses the antimeridian is cut there into a ``MultiLineString``
    (`antimeridian_parts`, RFC 7946 section 3.1.9).

    Parameters
    ----------
    path : Path
        Output ``.geojson`` (or ``.json``).
    lon_deg, lat_deg, h_m : ndarray, shape (N,)
        WGS 84 longitude, latitude (deg) and ellipsoidal height (m) of the vertices.
    properties : mapping
        The Feature's properties (JSON values).
    """
    _check(lon_deg, lat_deg)
    parts = [
        [[round(x, 9), round(y, 9), round(z, 4)] for x, y, z in part]
        for part in antimeridian_parts(lon_deg, lat_deg, h_m)
    ]
    geometry: dict[str, Any] = (
        {"type": "LineString", "coordinates": parts[0]}
        if len(parts) == 1
        else {"type": "MultiLineString", "coordinates": parts}
    )
    doc = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "geometry": geometry,
                "properties": dict(properties),
            }
        ],
    }
    text = json.dumps(doc, allow_nan=False, separators=(",", ":"))
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(text + "\n", encoding="utf-8")


def antimeridian_parts(
    lon_deg: FloatArray, lat_deg: FloatArray, h_m: FloatArray
) -> list[list[tuple[float, float, float]]]:
    """A line's vertices cut into parts where it crosses the antimeridian.

    Each segment is taken the short way round (179.99 to -179.99 deg crosses 180 deg,
    it does not run 359.98 deg west). Where a segment crosses, the part ends at 180 (or
    -180) deg and the next starts at -180 (or 180) deg, at the latitude and height
    interpolated linearly in longitude; a vertex on the antimeridian ends or starts
    parts as the side it joins.

    Parameters
    ----------
    lon_deg, lat_deg, h_m : ndarray, shape (N,)
        Longitude (deg, -180..180), latitude (deg) and height (m) of the vertices, N >= 2.

    Returns
    -------
    list of list of (lon_deg, lat_deg, h_m)
        The parts, each of at least two vertices, in order; one part when the line does
        not cross.
    """
    lon = [
        float(v) if -180.0 <= v <= 180.0 else (float(v) + 180.0) % 360.0 - 180.0 for v in lon_deg
    ]
    lat = [float(v) for v in lat_deg]
    h = [float(v) for v in h_m]
    part = [(lon[0], lat[0], h[0])]
    parts = [part]
    for i in range(1, len(lon)):
        a = part[-1][0]  # the previous vertex as its part has it (180 or -180 on the line)
        d = lon[i] - a
        if abs(lon[i]) == 180.0:  # on the antimeridian: on the side of the part
            b = 180.0 if a >= 0.0 else -180.0
        else:  # the short way round
            b = lon[i] if abs(d) <= 180.0 else a + (d + 180.0) % 360.0 - 180.0
        if -180.0 <= b <= 180.0:
            part.append((b, lat[i], h[i]))
            continue
        edge = 180.0 if b > 180.0 else -180.0
        f = (edge - a) / (b - a)  # in [0, 1): where the segment meets the antimeridian
        lat_x = lat[i - 1] + f * (lat[i] - lat[i - 1])
        h_x = h[i - 1] + f * (h[i] - h[i - 1])
        if f > 0.0:
            part.append((edge, lat_x, h_x))
        part = [(-edge, lat_x, h_x), (lon[i], lat[i], h[i])]
        parts.append(part)
    return [p for p in parts if len(p) >= 2]


def write_kml_line(
    path: Path, lon_deg: FloatArray, lat_deg: FloatArray, name: str, description: str = ""
) -> None:
    """Write a KML 2.2 document with one Placemark drawing the line on the ground.

    Parameters
    ----------
    path : Path
        Output ``.kml``.
    lon_deg, lat_deg : ndarray, shape (N,)
        WGS 84 longitude and latitude (deg) of the vertices.
    name, description : str
        Shown by the viewer (escaped).
    """
    _check(lon_deg, lat_deg)
    coords = " ".join(f"{x:.9f},{y:.9f}" for x, y in zip(lon_deg, lat_deg, strict=True))
    text = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<kml xmlns="http://www.opengis.net/kml/2.2">\n'
        f"<Document><name>{escape(name)}</name>\n"
        '<Style id="track"><LineStyle><color>ff0000ff</color><width>3</width></LineStyle>'
        "</Style>\n"
        f"<Placemark><name>{escape(name)}</name>"
        f"<description>{escape(description)}</description><styleUrl>#track</styleUrl>\n"
        "<LineString><tessellate>1</tessellate><altitudeMode>clampToGround</altitudeMode>\n"
        f"<coordinates>{coords}</coordinates>\n"
        "</LineString></Placemark>\n</Document>\n</kml>\n"
    )
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(text, encoding="utf-8")
