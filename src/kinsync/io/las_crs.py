"""The CRS of a LAS/LAZ file: OGC WKT or GeoTIFF keys, compound CRSs included (laspy).

LAS 1.4 point formats 6-10 declare their CRS in OGC WKT; formats 0-5 in GeoTIFF keys
(ASPRS LAS 1.4 R15, section 2.5), which name EPSG codes. laspy writes the keys of a
projected or geographic CRS only, and fails on a compound one (UTM + NAVD88 heights,
``EPSG:32618+5703``): `set_las_crs` writes the horizontal key, and for a compound CRS
the vertical one (``VerticalCSTypeGeoKey`` 4096, with ``VerticalUnitsGeoKey`` 4099,
the vertical CRS's unit: US survey feet for NAVD88 height (ftUS)), as PDAL and LAStools
read them; a geocentric CRS gets model type 3 (OGC GeoTIFF 1.1, 19-008r4). A CRS with no
EPSG code goes in WKT where the LAS version allows it (1.4), and is refused otherwise,
naming what to do.

The WKT is WKT1 as GDAL writes it (``WKT1_GDAL``, OGC 01-009, which LAS 1.4 R15 names
and PDAL writes; LAStools and GDAL before 3 read no other), a compound CRS as
``COMPD_CS``. WKT1 has no 3D geographic or 3D projected CRS: one whose third axis is
the ellipsoidal height (``EPSG:4979``, the 3D form of ``EPSG:2249``) is written as GDAL
writes it, a ``COMPD_CS`` with an ellipsoidal ``VERT_CS`` (datum type 2002), which PROJ
reads back as the 3D CRS. Only a CRS that WKT1 cannot represent (read back, it is
another CRS) is written as WKT2-2019, and `set_las_crs` says so.

Z's unit is declared with X and Y (`kinsync.crs_axes`): a 2D projected CRS in feet
(``EPSG:2249``), whose Z is the ellipsoidal height in metres, is declared by its 3D form
in WKT (an "ellipsoidal height (h)" axis in metres) and with ``VerticalUnitsGeoKey``
metre in GeoTIFF keys. `las_crs` reads a file's CRS back, a compound one from GeoTIFF
keys included (laspy reads only their horizontal part).

Files from other software (LAStools, TerraScan) often give ``VerticalUnitsGeoKey`` with
no vertical CRS (``VerticalCSTypeGeoKey`` absent, user-defined 32767 or no EPSG
vertical CRS): Z is then in that unit, but its height datum is unknown. `las_crs` reads
such a Z as the ellipsoidal height in the declared unit (the 3D form of the CRS, its
height axis in that unit, so that PROJ converts feet to metres); metre is what kinsync
writes for a 2D CRS in feet, read back as the 2D CRS as before. `read_las_crs` also gives
the sentence that says the datum was assumed: the consumer that needs the height
(`kinsync.io.cloud.cloud_crs`: ``kinsync validate``) prints it as a warning naming the
file and says to give ``--crs`` when Z is another height (a wrong datum, a geoid
undulation of tens of metres, leaves no cloud point near a control point: the check then
fails naming --crs; a wall's flatness does not depend on it). Commands that read a LAS
file's points in the scanner frame (georef, calibrate) do not use its CRS. A
``VerticalUnitsGeoKey`` that is no EPSG length unit is refused (`InputError`): Z's unit
is unknown.
"""

from __future__ import annotations

from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import laspy
import pyproj
from laspy.vlrs.known import (
    GeoAsciiParamsVlr,
    GeoKeyDirectoryVlr,
    GeoKeyEntryStruct,
    WktCoordinateSystemVlr,
)

from kinsync.crs_axes import declared_crs, output_units
from kinsync.errors import InputError
from kinsync.io.las_header import set_global_encoding_bit

__all__ = [
    "CRS_VLR_NAMES",
    "LasCrs",
    "georeferenced_crs_name",
    "las_crs",
    "las_crs_keys",
    "las_wkt",
    "read_las_crs",
    "set_las_crs",
]

CRS_VLR_NAMES = (
    "WktCoordinateSystemVlr",
    "GeoKeyDirectoryVlr",
    "GeoAsciiParamsVlr",
    "GeoDoubleParamsVlr",
)
_MODEL_TYPE = 1024  # GTModelTypeGeoKey: 1 projected, 2 geographic, 3 geocentric
_CITATION = 1026  # GTCitationGeoKey (ASCII)
_GEODETIC_CRS = 2048  # GeodeticCRSGeoKey (GeographicTypeGeoKey in GeoTIFF 1.0)
_PROJECTED_CRS = 3072  # ProjectedCRSGeoKey
_VERTICAL_CRS = 4096  # VerticalCSTypeGeoKey
_VERTICAL_UNITS = 4099  # VerticalUnitsGeoKey
_METRE = 9001  # EPSG unit of measure
_USER_DEFINED = 32767  # GeoTIFF key value: user-defined (no EPSG code)
_EPSG_RANGE = range(1024, 32767)  # GeoTIFF key values that are EPSG codes
_ASCII_TAG = 34737  # GeoAsciiParamsTag: where ASCII key values are stored


def _epsg(crs: pyproj.CRS) -> int | None:
    code = crs.to_epsg(min_confidence=90)
    return None if code is None or code not in _EPSG_RANGE else int(code)


def _unit_code(crs: pyproj.CRS) -> int | None:
    """EPSG code of the unit of ``crs``'s first axis (9001 metre, 9003 US survey foot)."""
    if not crs.axis_info:
        return None
    axis = crs.axis_info[0]
    if axis.unit_auth_code == "EPSG" and axis.unit_code:
        return int(axis.unit_code)
    unit = pyproj.get_units_map(auth_name="EPSG", category="linear").get(axis.unit_name)
    if unit is None or abs(float(unit.conv_factor) - axis.unit_conversion_factor) > 1e-12:
        return None
    return int(unit.code)


def las_crs_keys(crs: pyproj.CRS) -> dict[int, int] | None:
    """GeoTIFF key id -> EPSG value for ``crs``, or None when a code is missing.

    Parameters
    ----------
    crs : pyproj.CRS
        Projected, geographic, geocentric, or compound (one of these + vertical).
    """
    horizontal, vertical = crs, None
    if crs.is_compound:
        parts = crs.sub_crs_list
        if len(parts) != 2 or not parts[1].is_vertical:
            return None
        horizontal, vertical = parts
    code = _epsg(horizontal)
    if code is None:
        return None
    if horizontal.is_projected:
        keys = {_MODEL_TYPE: 1, _PROJECTED_CRS: code}
    elif horizontal.is_geocentric:
        keys = {_MODEL_TYPE: 3, _GEODETIC_CRS: code}
    elif horizontal.is_geographic:
        keys = {_MODEL_TYPE: 2, _GEODETIC_CRS: code}
    else:
        return None
    if vertical is not None:
        vertical_code, unit_code = _epsg(vertical), _unit_code(vertical)
        if vertical_code is None or unit_code is None:
            return None
        keys |= {_VERTICAL_CRS: vertical_code, _VERTICAL_UNITS: unit_code}
    elif horizontal.is_projected and output_units(crs)[0] != output_units(crs)[2]:
        keys |= {_VERTICAL_UNITS: _METRE}  # X, Y in feet, Z the ellipsoidal height (m)
    return keys


def _geotiff_vlrs(keys: dict[int, int], citation: str) -> tuple[Any, Any]:
    text = citation.encode("ascii", "replace").decode("ascii") + "|"
    entries = []
    for key_id, value in sorted({**keys, _CITATION: -1}.items()):
        entry = GeoKeyEntryStruct()
        entry.id = key_id
        if key_id == _CITATION:
            entry.tiff_tag_location, entry.count, entry.value_offset = _ASCII_TAG, len(text), 0
        else:
            entry.tiff_tag_location, entry.count, entry.value_offset = 0, 1, value
        entries.append(entry)
    directory = GeoKeyDirectoryVlr()
    directory.geo_keys_header.number_of_keys = len(entries)
    directory.geo_keys = entries
    ascii_vlr = GeoAsciiParamsVlr()
    ascii_vlr.strings = [text]
    return directory, ascii_vlr


def _ellipsoidal_compound_wkt1(crs: pyproj.CRS) -> str | None:
    """WKT1 of a 3D geographic/projected CRS as GDAL writes it, or None (see module)."""
    axes = crs.axis_info
    if crs.is_compound or len(axes) != 3 or not (crs.is_geographic or crs.is_projected):
        return None
    height = axes[2]
    if "ellipsoidal height" not in height.name.lower():
        return None
    try:
        horizontal = crs.to_2d().to_wkt("WKT1_GDAL")
    except pyproj.exceptions.CRSError:
        return None
    if not horizontal:
        return None
    unit = f'UNIT["{height.unit_name}",{height.unit_conversion_factor!r}'
    if height.unit_auth_code and height.unit_code:
        unit += f',AUTHORITY["{height.unit_auth_code}","{height.unit_code}"]'
    name = crs.name.replace('"', "'")
    return (
        f'COMPD_CS["{name}",{horizontal},VERT_CS["ellipsoidal height",'
        f'VERT_DATUM["Ellipsoid",2002],{unit}],AXIS["ellipsoidal height",UP]]]'
    )


def _reads_back(wkt: str | None, crs: pyproj.CRS) -> bool:
    """Whether ``wkt`` is ``crs``: its axes (names aside) and everything else."""
    if not wkt:
        return False
    try:
        back = pyproj.CRS.from_wkt(wkt)
    except pyproj.exceptions.CRSError:
        return False

    def axes(c: pyproj.CRS) -> list[tuple[str, str, float]]:
        return [
            (a.direction, a.unit_name, round(a.unit_conversion_factor, 12)) for a in c.axis_info
        ]

    return bool(back.equals(crs, ignore_axis_order=True)) and axes(back) == axes(crs)


def las_wkt(crs: pyproj.CRS) -> tuple[str, bool]:
    """The WKT a LAS/LAZ file declares ``crs`` in: WKT1 (GDAL) where it represents it.

    Parameters
    ----------
    crs : pyproj.CRS
        The CRS as declared (`kinsync.crs_axes.declared_crs`).

    Returns
    -------
    wkt : str
        WKT1 (``WKT1_GDAL``; a 3D geographic or projected CRS as a ``COMPD_CS`` with an
        ellipsoidal ``VERT_CS``), or WKT2-2019 where WKT1 cannot represent ``crs``.
    is_wkt1 : bool
        False when WKT2-2019 had to be written.
    """
    try:
        wkt1: str | None = crs.to_wkt("WKT1_GDAL")
    except pyproj.exceptions.CRSError:
        wkt1 = None
    for candidate in (wkt1, _ellipsoidal_compound_wkt1(crs)):
        if candidate and _reads_back(candidate, crs):
            return candidate, True
    return crs.to_wkt(), False


def _add_wkt(header: laspy.LasHeader, crs: pyproj.CRS, path: Path) -> str | None:
    """Declare ``crs`` in a WKT VLR (`las_wkt`); the note when it is WKT2."""
    wkt, is_wkt1 = las_wkt(crs)
    header.vlrs.append(WktCoordinateSystemVlr(wkt))
    set_global_encoding_bit(header, laspy.header.GlobalEncoding.WKT_MASK, on=True)
    if is_wkt1:
        return None
    return (
        f"{path}: its CRS {crs.name!r} cannot be written as WKT1 (OGC 01-009, which LAS 1.4 "
        "names): it is declared in WKT2-2019, which PDAL, GDAL 3 and laspy read but older "
        "readers (LAStools, GDAL 2) do not"
    )


def set_las_crs(header: laspy.LasHeader, crs: pyproj.CRS, path: Path) -> str | None:
    """Declare ``crs`` in ``header``, replacing any CRS records it had.

    Parameters
    ----------
    header : laspy.LasHeader
        Header of the file being written (its point format and version decide the
        encoding: WKT for formats 6-10, GeoTIFF keys for 0-5).
    crs : pyproj.CRS
        The coordinates' CRS.
    path : Path
        The file, for messages.

    Returns
    -------
    str or None
        The warning when the CRS had to be declared in WKT2-2019 (`las_wkt`), or None.

    Raises
    ------
    InputError
        A CRS without EPSG codes for a point format 0-5 file older than LAS 1.4.
    """
    for name in CRS_VLR_NAMES:
        with suppress(IndexError):
            header.vlrs.extract(name)
        if header.evlrs is not None:
            with suppress(IndexError):
                header.evlrs.extract(name)
    if header.point_format.id >= 6:
        return _add_wkt(header, declared_crs(crs), path)
    keys = las_crs_keys(crs)
    if keys is not None:
        set_global_encoding_bit(header, laspy.header.GlobalEncoding.WKT_MASK, on=False)
        header.vlrs.extend(_geotiff_vlrs(keys, crs.name))
        return None
    if header.version.minor >= 4:
        return _add_wkt(header, declared_crs(crs), path)
    msg = (
        f"{path}: LAS {header.version} point format {header.point_format.id} declares its "
        f"CRS with EPSG codes, and {crs.name!r} has none; give --crs as EPSG codes "
        "(e.g. EPSG:32619 or EPSG:32618+5703) or convert the input to LAS 1.4"
    )
    raise InputError(msg)


def _geo_keys(header: laspy.LasHeader) -> dict[int, int]:
    records = list(header.vlrs) + list(header.evlrs or [])
    return {
        int(k.id): int(k.value_offset)
        for v in records
        if isinstance(v, GeoKeyDirectoryVlr)
        for k in v.geo_keys
        if k.tiff_tag_location == 0
    }


@dataclass(frozen=True)
class LasCrs:
    """The CRS a LAS/LAZ header declares, and what was assumed reading it.

    Attributes
    ----------
    crs : pyproj.CRS or None
        The CRS of X, Y, Z (None: the file declares none).
    note : str or None
        When Z's height datum is unknown (``VerticalUnitsGeoKey`` with no usable vertical
        CRS): the sentence saying so and that Z is taken as the ellipsoidal height.
    """

    crs: pyproj.CRS | None
    note: str | None = None


def _length_unit(code: int) -> Any:
    """The EPSG length unit ``code`` (pyproj ``Unit``), or None."""
    units = pyproj.get_units_map(auth_name="EPSG", category="linear").values()
    return next((u for u in units if u.code == str(code) and not u.deprecated), None)


def _with_height_unit(crs: pyproj.CRS, unit: Any) -> pyproj.CRS:
    """The 3D form of a 2D ``crs`` whose ellipsoidal height axis is in ``unit``."""
    doc = crs.to_3d().to_json_dict()
    doc["coordinate_system"]["axis"][2]["unit"] = {
        "type": "LinearUnit",
        "name": unit.name,
        "conversion_factor": float(unit.conv_factor),
        "id": {"authority": "EPSG", "code": int(unit.code)},
    }
    return pyproj.CRS.from_json_dict(doc)


def _vertical_key_text(code: int | None) -> str:
    if code is None:
        return "no VerticalCSTypeGeoKey (4096)"
    if code == _USER_DEFINED:
        return "VerticalCSTypeGeoKey (4096) 32767, user-defined"
    return f"VerticalCSTypeGeoKey (4096) {code}, no EPSG vertical CRS"


def _vertical(code: int | None) -> pyproj.CRS | None:
    """The EPSG vertical CRS ``code`` names, or None."""
    if code is None or code not in _EPSG_RANGE:
        return None
    try:
        vertical = pyproj.CRS.from_epsg(code)
    except pyproj.exceptions.CRSError:
        return None
    return vertical if vertical.is_vertical else None


def read_las_crs(header: laspy.LasHeader) -> LasCrs:
    """The CRS a LAS/LAZ header declares, with the note on an assumed height datum.

    WKT first (as laspy reads it); else the GeoTIFF keys, with their vertical CRS
    (``VerticalCSTypeGeoKey``, an EPSG vertical CRS) making a compound CRS, so that Z is
    read in the unit and datum it was written in. Without a usable vertical CRS, a
    ``VerticalUnitsGeoKey`` other than metre makes Z the ellipsoidal height in that unit
    (the CRS's 3D form), with a note (module docstring).

    Raises
    ------
    InputError
        A ``VerticalUnitsGeoKey`` that is no EPSG length unit (the message has no path:
        the caller adds it).
    """
    records = list(header.vlrs) + list(header.evlrs or [])
    for record in records:
        if isinstance(record, WktCoordinateSystemVlr):
            from_wkt: pyproj.CRS | None = record.parse_crs()
            if from_wkt is not None:
                return LasCrs(from_wkt)
    crs: pyproj.CRS | None = header.parse_crs()
    if crs is None or crs.is_compound or crs.is_geocentric:
        return LasCrs(crs)
    keys = _geo_keys(header)
    vertical_code = keys.get(_VERTICAL_CRS)
    vertical = _vertical(vertical_code)
    if vertical is not None:
        return LasCrs(pyproj.crs.CompoundCRS(f"{crs.name} + {vertical.name}", [crs, vertical]))
    unit_code = keys.get(_VERTICAL_UNITS)
    if unit_code is None:
        return LasCrs(crs)
    unit = _length_unit(unit_code)
    if unit is None:
        msg = (
            f"the GeoTIFF key VerticalUnitsGeoKey (4099) is {unit_code}, no EPSG length "
            "unit: Z's unit is unknown"
        )
        raise InputError(msg)
    if unit_code == _METRE and vertical_code is None:
        return LasCrs(crs)  # what kinsync writes for a 2D CRS in feet: Z ellipsoidal (m)
    note = (
        f"Z's unit is {unit.name} (VerticalUnitsGeoKey (4099) {unit_code}), with "
        f"{_vertical_key_text(vertical_code)}: its height datum is unknown, Z is taken as "
        f"the ellipsoidal height ({unit.name})"
    )
    return LasCrs(crs if unit_code == _METRE else _with_height_unit(crs, unit), note)


def las_crs(header: laspy.LasHeader) -> pyproj.CRS | None:
    """The CRS a LAS/LAZ header declares, or None (`read_las_crs`).

    Raises
    ------
    InputError
        A ``VerticalUnitsGeoKey`` that is no EPSG length unit.
    """
    return read_las_crs(header).crs


def georeferenced_crs_name(crs_wkt: str | None) -> str | None:
    """A LAS header's CRS as ``EPSG:32619`` (or its name) when it is a map or earth CRS.

    Parameters
    ----------
    crs_wkt : str or None
        The header's CRS as WKT (`LasInfo.crs_wkt`), or None.

    Returns
    -------
    str or None
        ``AUTHORITY:CODE`` (or the CRS's name) of a projected, geographic or geocentric
        CRS: the file's coordinates are already georeferenced, not scanner-frame ones;
        None for no CRS, an unreadable one or an engineering (local) CRS.
    """
    if crs_wkt is None:
        return None
    try:
        crs = pyproj.CRS.from_wkt(crs_wkt)
    except pyproj.exceptions.CRSError:
        return None
    if not (crs.is_projected or crs.is_geographic or crs.is_geocentric):
        return None
    authority = crs.to_authority()
    return ":".join(authority) if authority is not None else crs.name
