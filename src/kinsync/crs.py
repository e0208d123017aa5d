"""Coordinate reference systems: transformations between ECEF and a user's CRS (pyproj).

Georeferencing ends in Earth-centred coordinates of the trajectory's frame (WGS 84,
EPSG:4978, unless the trajectory is known to be in another one, e.g. ITRF2014,
EPSG:7789). `plan_ecef_to_crs` chooses, once, the PROJ operation from there to the
user's CRS for the data's area, checks what a surveyor must not get silently wrong, and
says what it chose (`CrsTransformInfo`: the PROJ pipeline, its accuracy, the coordinate
epoch, the kind of heights):

- a compound CRS (``EPSG:32618+5703``: UTM + NAVD88 heights) needs a geoid model; when
  PROJ has none installed it would quietly leave ellipsoidal heights under the
  orthometric label (PROJ's "ballpark vertical transformation"), tens of metres off.
  That is refused, naming the grid PROJ wants and how to get it, unless the user gives
  a geoid grid (``geoid``): then heights are ``H = h - N`` with ``N`` read from it;
- a time-dependent transformation (between ITRF and NAD83(CSRS) realisations, say) is
  evaluated at a coordinate epoch: the one given, or the observation epoch of the
  data; neither known is an error;
- a datum change PROJ can only do as a "ballpark" (no parameters) or to worse than
  `COARSE_ACCURACY_M`, and data outside the CRS's area of use (a UTM zone far from
  the data), are warnings.

The plan (`CrsPlan`) holds PROJ pipeline strings, so that every worker process of a
georeferencing run rebuilds exactly the operation that was reported.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import pyproj.database
import pyproj.enums
from pyproj.aoi import AreaOfInterest
from pyproj.transformer import Transformer, TransformerGroup

from kinsync._crs_grids import check_grids_reachable, missing_grid_message, pipeline_text
from kinsync._typing import FloatArray
from kinsync.crs_axes import VerticalAxis, mixed_units_note, output_units, vertical_axis
from kinsync.errors import InputError
from kinsync.frames import longitude_span_deg, mean_longitude_deg

__all__ = [
    "COARSE_ACCURACY_M",
    "ECEF_WGS84",
    "CrsPlan",
    "CrsTransformInfo",
    "DataArea",
    "crs_plan_transformer",
    "crs_to_ecef_transformer",
    "data_area",
    "ecef_to_crs_transformer",
    "plan_ecef_to_crs",
    "sample_rows",
    "utm_zone_of",
]

ECEF_WGS84 = "EPSG:4978"
COARSE_ACCURACY_M = 0.5  # a datum change PROJ rates worse than this gets a warning
_EPOCH_RANGE_YEAR = (1980.0, 2100.0)
# Two epochs 30 years apart move a time-dependent transformation's output by centimetres
# to metres; these bounds (about 1 µm) separate that from rounding.
_TIME_TEST_EPOCHS = (2000.0, 2030.0)
_TIME_TOL_DEG = 1e-11
_TIME_TOL_M = 1e-6
_EQUATOR_ECEF_M = np.array([[6378137.0, 0.0, 0.0]])  # probe when no data are given


@dataclass(frozen=True)
class CrsPlan:
    """What a process needs to rebuild a chosen transformation (hashable, picklable).

    Attributes
    ----------
    crs : str
        The target CRS as the user gave it.
    pipeline : str or None
        PROJ pipeline from ECEF to the target (easting/longitude first); None when the
        target is the ECEF frame itself.
    height_pipeline : str or None
        With a geoid grid: PROJ pipeline from ECEF to ``(lon, lat, H)``, ``H`` the
        orthometric height; the target's horizontal coordinates still come from
        ``pipeline``.
    epoch_year : float or None
        Coordinate epoch (decimal year) at which a time-dependent pipeline is evaluated;
        None when the pipeline does not depend on time.
    """

    crs: str
    pipeline: str | None
    height_pipeline: str | None = None
    epoch_year: float | None = None

    def __str__(self) -> str:
        return self.crs


@dataclass(frozen=True)
class CrsTransformInfo:
    """What transformation was used, for the user to read and to keep with the results.

    Attributes
    ----------
    source, target : str
        Names (and codes) of the trajectory's ECEF frame and of the output CRS.
    operation : str
        PROJ's description of the operation.
    proj_pipeline : str
        The PROJ pipeline (with the geoid step, when a geoid grid gives the heights).
    accuracy_m : float or None
        PROJ's accuracy of the operation (m); None when PROJ does not know it.
    time_dependent : bool
        Whether the operation depends on the coordinate epoch.
    epoch_year : float or None
        The coordinate epoch used (decimal year), when time-dependent or given.
    heights : str
        What the output heights are (ellipsoidal, orthometric from which model, none).
    geoid : str or None
        The geoid grid file given by the user.
    ballpark : bool
        Whether PROJ applies a "ballpark" step (a datum change without parameters).
    units : tuple of 3 str
        Units of the output X, Y, Z (``metre``, ``degree``, ``US survey foot``, ...):
        a 2D projected CRS in feet gives X, Y in feet and Z, its ellipsoidal height, in
        metres (`kinsync.crs_axes.output_units`).
    warnings : tuple of str
        What the user should know (ballpark datum change, coarse accuracy, data outside
        the CRS's area of use, an epoch that changes nothing).
    """

    source: str
    target: str
    operation: str
    proj_pipeline: str
    accuracy_m: float | None
    time_dependent: bool
    epoch_year: float | None
    heights: str
    geoid: str | None = None
    ballpark: bool = False
    units: tuple[str, str, str] = ("metre", "metre", "metre")
    warnings: tuple[str, ...] = field(default=())

    def as_document(self) -> dict[str, Any]:
        """The information as a JSON-ready mapping."""
        return {
            "source": self.source,
            "target": self.target,
            "operation": self.operation,
            "proj_pipeline": self.proj_pipeline,
            "accuracy_m": self.accuracy_m,
            "time_dependent": self.time_dependent,
            "epoch_year": self.epoch_year,
            "heights": self.heights,
            "geoid": self.geoid,
            "ballpark": self.ballpark,
            "units": dict(zip(("X", "Y", "Z"), self.units, strict=True)),
            "warnings": list(self.warnings),
        }


def _parse_crs(text: str, option: str) -> pyproj.CRS:
    try:
        return pyproj.CRS.from_user_input(text)
    except pyproj.exceptions.CRSError as err:
        msg = f"{option} {text!r}: unknown coordinate reference system ({err}); e.g. EPSG:32619"
        raise InputError(msg) from err


def _name(crs: pyproj.CRS) -> str:
    authority = crs.to_authority(min_confidence=90)
    return f"{crs.name} ({':'.join(authority)})" if authority else crs.name


def _is_ecef_wgs84(crs: pyproj.CRS) -> bool:
    return bool(crs.equals(pyproj.CRS.from_epsg(4978), ignore_axis_order=True))


def _lonlat_of(sample_ecef_m: FloatArray) -> FloatArray:
    """WGS 84 longitude, latitude (deg) of ECEF points (a few metres of datum do not matter)."""
    to_geo = Transformer.from_crs(4978, 4979, always_xy=True)
    lon, lat, _ = to_geo.transform(sample_ecef_m[:, 0], sample_ecef_m[:, 1], sample_ecef_m[:, 2])
    return np.column_stack([lon, lat]).astype(np.float64)


_MIN_AREA_SIDE_DEG = 1e-6  # about 0.1 m: the smallest area of interest handed to PROJ


def _area(lonlat_deg: FloatArray | None) -> Any:  # pyproj's stubs name two AreaOfInterest
    """The data's longitude/latitude box, at least `_MIN_AREA_SIDE_DEG` on each side.

    PROJ 9.2 (pyproj 3.6.0's wheels) finds no operation at all for a box of zero width
    or height (a static trajectory, or a line driven due north). Across the antimeridian
    the box's west edge is east of its east edge, as PROJ takes it.
    """
    if lonlat_deg is None or not len(lonlat_deg):
        return None
    lat = lonlat_deg[:, 1]
    west, east = longitude_span_deg(lonlat_deg[:, 0])
    pad_lon = max(0.0, _MIN_AREA_SIDE_DEG - (east - west) % 360.0) / 2.0
    pad_lat = max(0.0, _MIN_AREA_SIDE_DEG - float(lat.max() - lat.min())) / 2.0
    west, east = west - pad_lon, east + pad_lon
    if west <= east:  # not across the antimeridian: the box stops at it
        west, east = max(-180.0, west), min(180.0, east)
    return AreaOfInterest(
        west_lon_degree=(west + 180.0) % 360.0 - 180.0 if west < -180.0 else west,
        south_lat_degree=max(-90.0, float(lat.min()) - pad_lat),
        east_lon_degree=(east + 180.0) % 360.0 - 180.0 if east > 180.0 else east,
        north_lat_degree=min(90.0, float(lat.max()) + pad_lat),
    )


def _best(
    source: pyproj.CRS, target: pyproj.CRS, area: Any
) -> tuple[Transformer, TransformerGroup]:
    """PROJ's best instantiable operation for the area (grids it lacks left out)."""
    try:
        with warnings.catch_warnings():  # a missing grid: said by the caller, named
            warnings.simplefilter("ignore", UserWarning)
            group = TransformerGroup(source, target, always_xy=True, area_of_interest=area)
    except pyproj.exceptions.ProjError as err:
        msg = f"no transformation from {_name(source)} to {_name(target)} ({err})"
        raise InputError(msg) from err
    if not group.transformers:
        msg = f"no transformation from {_name(source)} to {_name(target)} known to PROJ"
        raise InputError(msg)
    return group.transformers[0], group


def _ballpark_vertical(transformer: Transformer) -> bool:
    return any(
        "ballpark vertical" in op.name.lower() for op in transformer.operations or () if op.name
    )


def _ballpark(transformer: Transformer) -> bool:
    return any(op.has_ballpark_transformation for op in transformer.operations or ())


def _geoid_pipeline(to_geographic: Transformer, geoid: str, vertical: VerticalAxis | None) -> str:
    """ECEF -> (lon, lat, h) of the horizontal datum, then ``H = h - N`` from the grid.

    ``H`` comes out in metres, up; it is then converted to the vertical CRS's unit
    (``EPSG:6360``, NAVD88 height (ftUS): US survey feet) and direction (a depth CRS:
    positive down), as PROJ's own geoid operation would give it.
    """
    text = (
        f"{pipeline_text(to_geographic)} step proj=unitconvert xy_in=deg xy_out=rad "
        f'step proj=vgridshift grids="{geoid}" multiplier=-1 '
        "step proj=unitconvert xy_in=rad xy_out=deg"
    )
    if vertical is not None and vertical.metres_per_unit != 1.0:
        text += f" step proj=unitconvert z_in=m z_out={vertical.metres_per_unit!r}"
    if vertical is not None and not vertical.up:
        text += " step proj=axisswap order=1,2,-3"
    return text


def _check_geoid_file(geoid: str) -> str:
    """The grid's absolute path, as the pipeline quotes it (links kept, not resolved).

    A PROJ pipeline takes a quoted path with spaces, but reads a comma as the separator
    of a grid list and has no escape for a double quote.
    """
    path = Path(geoid).expanduser()
    if not path.is_file():
        msg = f"--geoid {geoid}: file not found (a geoid grid: GTX or GeoTIFF of N, in metres)"
        raise InputError(msg)
    text = str(path.absolute())
    if "," in text or '"' in text:
        msg = (
            f"--geoid {geoid}: PROJ cannot read a grid whose path has a comma or a double "
            "quote; copy or link it to a path without them"
        )
        raise InputError(msg)
    return text


def _time_dependent(pipeline: str, sample_ecef_m: FloatArray, geographic: bool) -> bool:
    transformer = Transformer.from_pipeline(pipeline)
    x, y, z = sample_ecef_m[:1, 0], sample_ecef_m[:1, 1], sample_ecef_m[:1, 2]
    outs = [np.array(transformer.transform(x, y, z, np.full(1, t))) for t in _TIME_TEST_EPOCHS]
    delta = np.abs(outs[0][:3] - outs[1][:3])[:, 0]
    tol = np.array([_TIME_TOL_DEG, _TIME_TOL_DEG, _TIME_TOL_M]) if geographic else _TIME_TOL_M
    return bool(np.any(delta > tol))


def _area_warnings(target: pyproj.CRS, lonlat_deg: FloatArray | None) -> list[str]:
    """Data outside the CRS's area of use: a UTM zone far from the data, say."""
    horizontal = target.sub_crs_list[0] if target.is_compound else target
    area = horizontal.area_of_use
    if lonlat_deg is None or not len(lonlat_deg) or area is None or not horizontal.is_projected:
        return []
    lon, lat = lonlat_deg[:, 0], lonlat_deg[:, 1]
    west, south, east, north = area.bounds
    lon_in = (lon >= west) & (lon <= east) if west <= east else (lon >= west) | (lon <= east)
    inside = lon_in & (lat >= south) & (lat <= north)
    if np.all(inside):
        return []
    middle = west + 0.5 * ((east - west) % 360.0)  # of the area of use
    off_deg = np.abs((lon - middle + 180.0) % 360.0 - 180.0)
    worst = int(np.argmax(np.where(inside, -1.0, off_deg)))
    factors = pyproj.Proj(horizontal).get_factors(
        float(lon[worst]), float(lat[worst]), errcheck=False
    )
    scale = float(factors.meridional_scale)
    lon_west, lon_east = longitude_span_deg(lon)
    across = lon_west > lon_east  # then the data lie close to 180: more decimals
    lon_text = (
        f"{lon_west:.4f} to {lon_east:.4f} deg, across the antimeridian"
        if across
        else f"{lon_west:.2f} to {lon_east:.2f} deg"
    )
    text = (
        f"the data (longitude {lon_text}, latitude "
        f"{lat.min():.2f} to {lat.max():.2f} deg) lie outside the area of use of "
        f"{_name(horizontal)} (longitude {west:g} to {east:g}, latitude {south:g} to "
        f"{north:g})"
    )
    if math.isfinite(scale):
        text += f"; its scale factor there is {scale:.6f} ({(scale - 1.0) * 1e6:+.0f} ppm)"
    suggestion = _suggest_projected(horizontal, lonlat_deg)
    if suggestion:
        text += f"; the data's zone is {suggestion}"
    return [text]


def _suggest_projected(horizontal: pyproj.CRS, lonlat_deg: FloatArray) -> str | None:
    """The UTM CRS of the same geodetic CRS for the data's centre, when ``horizontal`` is UTM.

    Beyond UTM's limits (84 deg N, 80 deg S): the WGS 84 UPS CRS of that pole.
    """
    if " / UTM zone " not in horizontal.name:
        return None
    lon_c = mean_longitude_deg(lonlat_deg[:, 0])
    lat_c = float(np.mean(lonlat_deg[:, 1]))
    ups = ups_of(lat_c)
    if ups is not None:
        name = pyproj.CRS.from_user_input(ups[1]).name
        return f"{ups[0]} (beyond UTM's {_utm_limit_text(lat_c)}): {name} ({ups[1]})"
    zone, hemisphere = utm_zone_of(lon_c, lat_c)
    wanted = f"{horizontal.name.split(' / ')[0]} / UTM zone {zone}{hemisphere}"
    if wanted == horizontal.name:  # data at the zone's edge: no other zone to suggest
        return None
    infos = pyproj.database.query_crs_info(
        auth_name="EPSG",
        pj_types=pyproj.enums.PJType.PROJECTED_CRS,
        area_of_interest=AreaOfInterest(lon_c, lat_c, lon_c, lat_c),
    )
    for info in infos:
        if info.name == wanted and not info.deprecated:
            return f"{zone}{hemisphere}: {info.name} ({info.auth_name}:{info.code})"
    return f"{zone}{hemisphere}"


@dataclass(frozen=True)
class DataArea:
    """Where data lie and which UTM zone suits them.

    Attributes
    ----------
    lat_deg, lon_deg, h_m : tuple of float
        (min, max) latitude, (west, east) longitude (deg, WGS 84; longitude -180..180,
        the shortest arc holding the data: west > east across the antimeridian) and
        (min, max) ellipsoidal height (m).
    utm_zone : int or None
        UTM zone of the data's centre; None beyond UTM's limits (84 deg N, 80 deg S),
        where UPS is suggested. ``utm_hemisphere`` "N" or "S".
    utm_epsg : str
        The WGS 84 UTM CRS of that zone (``EPSG:326zz`` north, ``EPSG:327zz`` south);
        beyond UTM's limits the WGS 84 UPS CRS (``EPSG:32661`` north, ``EPSG:32761``
        south).
    zones_spanned : tuple of int
        Every UTM zone the data reach within UTM's limits, west to east (more than one:
        choose one for the whole job); across the antimeridian 60 comes before 1.
    """

    lat_deg: tuple[float, float]
    lon_deg: tuple[float, float]
    h_m: tuple[float, float]
    utm_zone: int | None
    utm_hemisphere: str
    utm_epsg: str
    zones_spanned: tuple[int, ...]

    @property
    def zone_name(self) -> str:
        """``19N``, or ``UPS North`` / ``UPS South`` beyond UTM's limits."""
        if self.utm_zone is None:
            return "UPS North" if self.utm_hemisphere == "N" else "UPS South"
        return f"{self.utm_zone}{self.utm_hemisphere}"

    def as_document(self) -> dict[str, Any]:
        """JSON-ready mapping (``utm_zone`` is `zone_name`: ``UPS North`` beyond 84 deg N)."""
        return {
            "lat_deg": list(self.lat_deg),
            "lon_deg": list(self.lon_deg),
            "h_m": list(self.h_m),
            "utm_zone": self.zone_name,
            "utm_epsg": self.utm_epsg,
            "zones_spanned": list(self.zones_spanned),
        }


def data_area(lat_deg: FloatArray, lon_deg: FloatArray, h_m: FloatArray) -> DataArea:
    """Extent and suggested UTM zone of geodetic positions.

    Parameters
    ----------
    lat_deg, lon_deg, h_m : (n,) ndarray
        WGS 84 latitude, longitude (deg) and ellipsoidal height (m), n >= 1.
    """
    lat = np.asarray(lat_deg, dtype=np.float64)
    lon = np.asarray(lon_deg, dtype=np.float64)
    h = np.asarray(h_m, dtype=np.float64)
    west, east = longitude_span_deg(lon)  # the shortest arc: across the antimeridian too
    lon_c = west + 0.5 * ((east - west) % 360.0)
    lat_c = float(0.5 * (lat.min() + lat.max()))
    zone, hemisphere = utm_zone_of(lon_c, lat_c)
    within = (lat >= UTM_SOUTH_LIMIT_DEG) & (lat <= UTM_NORTH_LIMIT_DEG)
    inside = zip(lon[within], lat[within], strict=True)
    zones = sorted({utm_zone_of(float(a), float(b))[0] for a, b in inside})
    if west > east:  # across the antimeridian: the zones west of it first (60 before 1)
        first = utm_zone_of(west, lat_c)[0]
        zones = [z for z in zones if z >= first] + [z for z in zones if z < first]
    ups = ups_of(lat_c)
    return DataArea(
        lat_deg=(float(lat.min()), float(lat.max())),
        lon_deg=(west, east),
        h_m=(float(h.min()), float(h.max())),
        utm_zone=None if ups else zone,
        utm_hemisphere=hemisphere,
        utm_epsg=ups[1] if ups else f"EPSG:{(32600 if hemisphere == 'N' else 32700) + zone}",
        zones_spanned=tuple(zones),
    )


UTM_NORTH_LIMIT_DEG = 84.0
"""UTM's northern limit (deg): north of it, UPS North (EPSG:32661)."""
UTM_SOUTH_LIMIT_DEG = -80.0
"""UTM's southern limit (deg): south of it, UPS South (EPSG:32761)."""


def ups_of(lat_deg: float) -> tuple[str, str] | None:
    """The WGS 84 UPS CRS for a latitude beyond UTM's limits, None within them.

    Parameters
    ----------
    lat_deg : float
        Latitude (deg).

    Returns
    -------
    tuple of str or None
        (``"UPS North"``, ``"EPSG:32661"``) north of 84 deg N, (``"UPS South"``,
        ``"EPSG:32761"``) south of 80 deg S.
    """
    if lat_deg > UTM_NORTH_LIMIT_DEG:
        return "UPS North", "EPSG:32661"
    if lat_deg < UTM_SOUTH_LIMIT_DEG:
        return "UPS South", "EPSG:32761"
    return None


def _utm_limit_text(lat_deg: float) -> str:
    return "84 deg N limit" if lat_deg > 0.0 else "80 deg S limit"


def utm_zone_of(lon_deg: float, lat_deg: float) -> tuple[int, str]:
    """UTM zone number and hemisphere ("N"/"S") of a point, Norway and Svalbard included.

    The zone by longitude only: UTM stops at 84 deg N and 80 deg S (`ups_of` names the
    polar CRS beyond).

    Parameters
    ----------
    lon_deg, lat_deg : float
        Longitude and latitude (deg).
    """
    lon = (lon_deg + 180.0) % 360.0 - 180.0
    zone = min(int((lon + 180.0) // 6.0) + 1, 60)
    if 56.0 <= lat_deg < 64.0 and 3.0 <= lon < 12.0:
        zone = 32
    if 72.0 <= lat_deg < 84.0 and 0.0 <= lon < 42.0:
        zone = 31 if lon < 9.0 else 33 if lon < 21.0 else 35 if lon < 33.0 else 37
    return zone, "N" if lat_deg >= 0.0 else "S"


def _resolve_epoch(
    time_dependent: bool,
    epoch_year: float | None,
    observation_epoch_year: float | None,
    crs_text: str,
) -> tuple[float | None, list[str]]:
    if epoch_year is not None and not (_EPOCH_RANGE_YEAR[0] <= epoch_year <= _EPOCH_RANGE_YEAR[1]):
        msg = (
            f"--epoch {epoch_year:g}: a coordinate epoch is a decimal year between "
            f"{_EPOCH_RANGE_YEAR[0]:g} and {_EPOCH_RANGE_YEAR[1]:g}, e.g. 2024.35"
        )
        raise InputError(msg)
    if not time_dependent:
        notes = (
            [
                (
                    f"--epoch {epoch_year:g} changes nothing: the transformation to "
                    f"{crs_text} does not depend on time"
                )
            ]
            if epoch_year is not None
            else []
        )
        return epoch_year, notes
    if epoch_year is not None:
        return epoch_year, []
    if observation_epoch_year is not None:
        return observation_epoch_year, []
    msg = (
        f"--crs {crs_text!r}: the transformation depends on time (plate motion between "
        "reference frames) and the data's date is unknown (times are not absolute GPS "
        "time); give the coordinate epoch with --epoch YEAR, e.g. 2024.35"
    )
    raise InputError(msg)


def plan_ecef_to_crs(
    crs: str,
    *,
    geoid: str | None = None,
    epoch_year: float | None = None,
    source_crs: str = ECEF_WGS84,
    sample_ecef_m: FloatArray | None = None,
    observation_epoch_year: float | None = None,
) -> tuple[CrsPlan, CrsTransformInfo]:
    """Choose and check the transformation from the trajectory's ECEF frame to ``crs``.

    Parameters
    ----------
    crs : str
        Output CRS, any pyproj user input (``EPSG:32619``, ``EPSG:32618+5703``, WKT).
    geoid : str, optional
        Path of a geoid grid (GTX, GeoTIFF): heights ``N`` of the geoid above the
        ellipsoid of ``crs``'s horizontal datum. Needs a compound ``crs`` (horizontal +
        vertical), whose heights become ``H = h - N``.
    epoch_year : float, optional
        Coordinate epoch (decimal year) for a time-dependent transformation.
    source_crs : str
        The geocentric CRS of the trajectory's positions (default WGS 84, EPSG:4978).
    sample_ecef_m : (n, 3) ndarray, optional
        Points of the data (m, ECEF): they pick the operation for the area, and test the
        geoid grid's coverage and the CRS's area of use.
    observation_epoch_year : float, optional
        The data's date (decimal year), the default epoch of a time-dependent
        transformation.

    Returns
    -------
    plan : CrsPlan
        For `crs_plan_transformer`.
    info : CrsTransformInfo
        What was chosen, with warnings.

    Raises
    ------
    InputError
        Unknown CRS; a compound CRS whose geoid grid PROJ lacks; a geoid grid that is
        missing, unreadable or does not cover the data; a time-dependent transformation
        with no epoch; a source CRS that is not geocentric.
    """
    target = _parse_crs(crs, "--crs")
    source = _parse_source(source_crs)
    sample = _parse_sample(sample_ecef_m)
    lonlat = None if sample is None else _lonlat_of(sample)
    area = _area(lonlat)
    if geoid is not None and not (target.is_compound and len(target.sub_crs_list) == 2):
        msg = (
            f"--geoid gives orthometric heights: name their vertical datum with a compound "
            f"--crs (horizontal+vertical, e.g. EPSG:32618+5703), not {crs!r}"
        )
        raise InputError(msg)
    if geoid is None and source.equals(target, ignore_axis_order=True):
        info = CrsTransformInfo(
            source=_name(source),
            target=_name(target),
            operation="none (coordinates stay in the trajectory's ECEF frame)",
            proj_pipeline="",
            accuracy_m=0.0,
            time_dependent=False,
            epoch_year=epoch_year,
            heights="none (ECEF X, Y, Z)",
        )
        return CrsPlan(crs, None, None, None), info
    if geoid is None:
        transformer, group = _best(source, target, area)
        if _ballpark_vertical(transformer):
            raise InputError(missing_grid_message(crs, group))
        check_grids_reachable(crs, transformer, group)
        pipeline = pipeline_text(transformer)
        height_pipeline = None
        heights = _heights_text(target, None)
    else:
        geoid = _check_geoid_file(geoid)
        horizontal = target.sub_crs_list[0]
        geographic_crs = horizontal.geodetic_crs
        if geographic_crs is None:
            msg = f"--crs {crs!r}: its horizontal part {horizontal.name} has no datum"
            raise InputError(msg)
        transformer, _ = _best(source, horizontal.to_3d(), area)
        to_geographic, _ = _best(source, geographic_crs.to_3d(), area)
        pipeline = pipeline_text(transformer)
        height_pipeline = _geoid_pipeline(to_geographic, geoid, vertical_axis(target))
        heights = _heights_text(target, geoid)
    geographic = target.is_geographic and not target.is_compound
    time_dependent = _time_dependent(
        pipeline, sample if sample is not None else _EQUATOR_ECEF_M, geographic
    )
    epoch, notes = _resolve_epoch(time_dependent, epoch_year, observation_epoch_year, crs)
    plan = CrsPlan(crs, pipeline, height_pipeline, epoch if time_dependent else None)
    if sample is not None:
        _check_output(plan, sample, geoid)
    ballpark = _ballpark(transformer)
    accuracy = float(transformer.accuracy) if transformer.accuracy >= 0 else None
    notes = [*notes, *_datum_warnings(source, target, ballpark, accuracy)]
    notes += _area_warnings(target, lonlat)
    units_note = mixed_units_note(target, crs)
    if units_note is not None:
        notes.append(units_note)
    info = CrsTransformInfo(
        source=_name(source),
        target=_name(target),
        operation=str(transformer.description),
        proj_pipeline=pipeline
        if height_pipeline is None
        else (f"{pipeline} ; heights: {height_pipeline}"),
        accuracy_m=accuracy,
        time_dependent=time_dependent,
        epoch_year=epoch,
        heights=heights,
        geoid=geoid,
        ballpark=ballpark,
        units=output_units(target),
        warnings=tuple(notes),
    )
    return plan, info


def _parse_source(source_crs: str) -> pyproj.CRS:
    source = _parse_crs(source_crs, "--trajectory-crs")
    if not source.is_geocentric:
        msg = (
            f"--trajectory-crs {source_crs!r} is {source.type_name}; give the geocentric "
            "CRS of the trajectory's frame, e.g. EPSG:4978 (WGS 84), EPSG:7789 (ITRF2014), "
            "EPSG:9988 (ITRF2020)"
        )
        raise InputError(msg)
    return source


def _parse_sample(sample_ecef_m: FloatArray | None) -> FloatArray | None:
    if sample_ecef_m is None:
        return None
    sample = np.asarray(sample_ecef_m, dtype=np.float64)
    if not (sample.ndim == 2 and sample.shape[1] == 3 and len(sample)):
        msg = f"sample_ecef_m must be (n, 3) with n >= 1, got shape {sample.shape}"
        raise InputError(msg)
    return sample


def _datum_warnings(
    source: pyproj.CRS, target: pyproj.CRS, ballpark: bool, accuracy: float | None
) -> list[str]:
    if ballpark:
        return [
            (
                f"PROJ has no parameters for the datum change from {_name(source)} to "
                f"{_name(target)} and applies none (a 'ballpark' step): coordinates may be a "
                "metre or more off; give the trajectory's frame with --trajectory-crs "
                "(e.g. EPSG:7789 for ITRF2014)"
            )
        ]
    if accuracy is not None and accuracy > COARSE_ACCURACY_M:
        return [
            (
                f"PROJ's transformation from {_name(source)} to {_name(target)} is accurate to "
                f"{accuracy:g} m only; if the trajectory is in a precise frame, say which with "
                "--trajectory-crs (e.g. EPSG:7789 for ITRF2014)"
            )
        ]
    return []


def _heights_text(target: pyproj.CRS, geoid: str | None) -> str:
    if target.is_compound:
        vertical = target.sub_crs_list[-1]
        model = f"geoid grid {geoid}" if geoid else "PROJ's geoid model"
        return f"orthometric: {vertical.name} ({model})"
    if target.is_geocentric:
        return "none (ECEF X, Y, Z)"
    geodetic = target.geodetic_crs
    datum = geodetic.datum.name if geodetic is not None and geodetic.datum else target.name
    return f"ellipsoidal ({datum})"


def _check_output(plan: CrsPlan, sample_ecef_m: FloatArray, geoid: str | None) -> None:
    """Transform the sample: a grid that does not cover the data fails here, named."""
    try:
        apply = crs_plan_transformer(plan)
        if apply is None:
            return
        out = apply(sample_ecef_m)
    except pyproj.exceptions.ProjError as err:
        what = f"--geoid {geoid}" if geoid else f"--crs {plan.crs!r}"
        msg = f"{what}: PROJ cannot transform the data ({err}); is the grid readable?"
        raise InputError(msg) from err
    bad = ~np.all(np.isfinite(out), axis=1)
    if np.any(bad):
        lon, lat = _lonlat_of(sample_ecef_m[bad][:1])[0]
        where = f"longitude {lon:.4f}, latitude {lat:.4f} deg"
        if geoid:
            msg = f"--geoid {geoid}: the grid does not cover the data (at {where})"
        else:
            msg = f"--crs {plan.crs!r}: the data (at {where}) do not transform to this CRS"
        raise InputError(msg)


@lru_cache(maxsize=16)
def crs_plan_transformer(plan: CrsPlan) -> Callable[[FloatArray], FloatArray] | None:
    """The function that applies ``plan`` to ``(n, 3)`` ECEF points; None for ECEF itself.

    The result has axis order easting/longitude first; with a geoid, the third column is
    the orthometric height. Cached: a worker builds each plan's transformers once.
    """
    if plan.pipeline is None:
        return None
    transformer = Transformer.from_pipeline(plan.pipeline)
    heights = (
        None if plan.height_pipeline is None else Transformer.from_pipeline(plan.height_pipeline)
    )
    epoch = plan.epoch_year

    def apply(pos_ecef_m: FloatArray) -> FloatArray:
        x, y, z = pos_ecef_m[:, 0], pos_ecef_m[:, 1], pos_ecef_m[:, 2]
        tt = None if epoch is None else np.full(len(x), epoch)
        e, n, u = transformer.transform(x, y, z, tt)[:3]
        if heights is not None:
            u = heights.transform(x, y, z, tt)[2]
        return np.column_stack([e, n, u]).astype(np.float64)

    return apply


@lru_cache(maxsize=8)
def ecef_to_crs_transformer(crs: str) -> Callable[[FloatArray], FloatArray] | None:
    """WGS 84 ECEF -> ``crs`` (axis order easting/longitude first), or None for ECEF itself.

    The plain form of `plan_ecef_to_crs`: no geoid grid, no data sample (PROJ's
    operation for the CRS as a whole), no epoch (a time-dependent operation is refused).
    """
    plan, _ = plan_ecef_to_crs(crs)
    return crs_plan_transformer(plan)


@lru_cache(maxsize=8)
def crs_to_ecef_transformer(crs_text: str) -> Callable[[FloatArray], FloatArray] | None:
    """Cloud CRS -> ECEF (axis order easting/longitude first), None for ECEF itself.

    A compound CRS whose geoid grid PROJ lacks is refused (see `plan_ecef_to_crs`).
    """
    crs = _parse_crs(crs_text, "--crs")
    if _is_ecef_wgs84(crs):
        return None
    transformer, group = _best(crs, pyproj.CRS.from_epsg(4978), None)
    if _ballpark_vertical(transformer):
        raise InputError(missing_grid_message(crs_text, group))
    check_grids_reachable(crs_text, transformer, group)

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


def sample_rows(n: int, count: int = 64) -> Sequence[int]:
    """Up to ``count`` row indices spread over ``n`` rows, first and last included.

    Parameters
    ----------
    n : int
        Number of rows (>= 0).
    count : int
        Most indices to give (>= 2 for the last row to be among them); default 64.

    Returns
    -------
    sequence of int
        Every row, ``range(n)``, when ``n <= count``; otherwise ``count`` or fewer
        distinct indices in increasing order, evenly spaced from 0 to ``n - 1``.
    """
    if n <= count:
        return range(n)
    return sorted({round(i) for i in np.linspace(0, n - 1, count)})
