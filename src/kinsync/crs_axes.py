"""The units of the X, Y, Z a CRS output holds, and the CRS that says so (pyproj).

`kinsync georef` and `kinsync trajectory export` write easting/longitude, northing/
latitude and a height in the output CRS. PROJ gives each axis in that CRS's unit: a
state plane CRS in US survey feet (``EPSG:2249``) gives X and Y in US survey feet. A
horizontal-only CRS has no height axis: PROJ passes the ellipsoidal height through in
metres (its 3D form, ``CRS.to_3d()``, says so: "ellipsoidal height (h)", metre). So
``EPSG:2249`` gives X, Y in US survey feet and Z in metres; ``EPSG:2249+6360`` (NAVD88
height (ftUS)) gives all three in US survey feet.

`output_units` names the unit of each output coordinate; `declared_crs` is the CRS a
file should declare so that a reader finds the same units (the 3D form when the height's
unit differs from the horizontal one); `mixed_units_note` is the sentence for the user
when the units differ; `coordinate_metadata` says both in a table's metadata (Parquet);
`vertical_axis` gives the unit and direction a geoid-derived
height must be converted to.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyproj

__all__ = [
    "VerticalAxis",
    "coordinate_metadata",
    "declared_crs",
    "mixed_units_note",
    "output_units",
    "vertical_axis",
]

_METRE = "metre"
_PLURAL = {"metre": "metres", "foot": "feet", "US survey foot": "US survey feet"}
# A compound CRS to suggest for heights in feet, by the horizontal unit (EPSG names).
_FEET_HEIGHTS = {
    "US survey foot": ("6360", "NAVD88 height (ftUS)"),
    "foot": ("8228", "NAVD88 height (ft)"),
}


@dataclass(frozen=True)
class VerticalAxis:
    """Unit and direction of a vertical CRS's axis.

    Attributes
    ----------
    unit : str
        Unit name (``metre``, ``US survey foot``, ``foot``).
    metres_per_unit : float
        Length of one unit in metres.
    up : bool
        True for heights, False for depths (positive down).
    """

    unit: str
    metres_per_unit: float
    up: bool


def _horizontal(crs: pyproj.CRS) -> pyproj.CRS:
    return crs.sub_crs_list[0] if crs.is_compound else crs


def vertical_axis(crs: pyproj.CRS) -> VerticalAxis | None:
    """The vertical axis of a compound ``crs`` (its last part), None for other CRSs."""
    if not crs.is_compound:
        return None
    vertical = crs.sub_crs_list[-1]
    if not vertical.is_vertical or not vertical.axis_info:
        return None
    axis = vertical.axis_info[0]
    return VerticalAxis(
        axis.unit_name, float(axis.unit_conversion_factor), axis.direction.lower() != "down"
    )


def output_units(crs: pyproj.CRS) -> tuple[str, str, str]:
    """Unit names of X, Y, Z as written in ``crs`` (easting/longitude first).

    Geocentric: metres; projected and geographic: the CRS's horizontal unit for X, Y and,
    for Z, the unit of its vertical CRS (compound), of its height axis (3D), or metres
    (a 2D CRS: the ellipsoidal height passes through in metres).
    """
    horizontal = _horizontal(crs)
    units = [a.unit_name for a in horizontal.axis_info]
    x_unit = units[0] if units else _METRE
    y_unit = units[1] if len(units) > 1 else x_unit
    vertical = vertical_axis(crs)
    if vertical is not None:
        z_unit = vertical.unit
    elif len(units) > 2:
        z_unit = units[2]
    else:
        z_unit = _METRE
    return x_unit, y_unit, z_unit


def _metre_height_needs_saying(crs: pyproj.CRS) -> bool:
    """A 2D projected CRS whose unit is not the metre: its Z (metres) is not its unit."""
    return (
        crs.is_projected
        and not crs.is_compound
        and len(crs.axis_info) == 2
        and output_units(crs)[0] != _METRE
    )


def declared_crs(crs: pyproj.CRS) -> pyproj.CRS:
    """The CRS a file declares for X, Y, Z written in ``crs``.

    ``crs`` itself, except a 2D projected CRS whose unit is not the metre: its 3D form
    (PROJ's promotion, axis "ellipsoidal height (h)" in metres), so that the file says
    that Z is an ellipsoidal height in metres under X, Y in feet.
    """
    return crs.to_3d() if _metre_height_needs_saying(crs) else crs


def mixed_units_note(crs: pyproj.CRS, crs_text: str) -> str | None:
    """The sentence telling the user that Z is not in the unit of X and Y, or None."""
    x_unit, _, z_unit = output_units(crs)
    if crs.is_geographic or crs.is_geocentric or x_unit == z_unit:
        return None
    if crs.is_compound:
        return (
            f"--crs {crs_text!r}: X and Y are in {x_unit}, Z in {z_unit} (the unit of its "
            f"vertical CRS {crs.sub_crs_list[-1].name})"
        )
    text = (
        f"--crs {crs_text!r} has no vertical axis: X and Y are in {x_unit}, Z is the "
        f"ellipsoidal height in {_PLURAL.get(z_unit, z_unit)} (LAS/LAZ and Parquet "
        "outputs declare it so)"
    )
    suggestion = _FEET_HEIGHTS.get(x_unit)
    code = crs.to_epsg(min_confidence=90)
    if suggestion is not None and code is not None:
        text += (
            f"; for heights in {x_unit}, give a compound CRS whose vertical part is in "
            f"{x_unit}, e.g. EPSG:{code}+{suggestion[0]} ({suggestion[1]}) in the United States"
        )
    return text


def coordinate_metadata(
    crs: pyproj.CRS, names: tuple[str, str, str] = ("X", "Y", "Z")
) -> tuple[dict[str, dict[str, str]], dict[str, str]]:
    """Table metadata for coordinates in ``crs``: each column's unit, and the CRS.

    Returns
    -------
    fields : dict
        ``{name: {"unit": unit}}`` for the three coordinate columns.
    table : dict
        ``{"crs": PROJJSON}`` of `declared_crs` (whose axes carry the same units).
    """
    fields = {name: {"unit": unit} for name, unit in zip(names, output_units(crs), strict=True)}
    return fields, {"crs": declared_crs(crs).to_json()}
