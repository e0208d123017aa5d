"""Trajectory export: a table in any CRS, or a line for a quick look (KML, GeoJSON).

`export_trajectory` reads any trajectory kinsync reads (`read_trajectory_file`) and
writes, by the output's suffix:

* ``.csv``/``.parquet``: one row per record, ``t_s`` (the input's time scale), ``X, Y,
  Z`` in the output CRS (axis order easting/longitude first, as ``kinsync georef``
  writes points; a Parquet file's metadata gives their units and the CRS,
  `kinsync.crs_axes.coordinate_metadata`), ``roll_deg, pitch_deg, yaw_deg`` (DIN 9300,
  yaw the true heading, not turned to grid north) and, when the input has them,
  ``vn_m_s, ve_m_s, vd_m_s``. The
  transformation is chosen as for georeferencing (`kinsync.crs.plan_ecef_to_crs`: a
  compound CRS with PROJ's geoid grid or ``geoid``, the coordinate epoch of a
  time-dependent one, the trajectory's own geocentric frame) and reported;
* ``.geojson``/``.json`` and ``.kml``: one line in WGS 84 longitude/latitude through at
  most ``max_vertices`` records (`kinsync.io.quicklook`), for a look in a GIS or a
  virtual globe. The positions are the trajectory's as read (no datum change).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyproj

from kinsync._typing import FloatArray
from kinsync.clock.leap_seconds import PLAUSIBLE_DATE_GPS_S, gps_to_decimal_year
from kinsync.crs import (
    ECEF_WGS84,
    CrsTransformInfo,
    crs_plan_transformer,
    plan_ecef_to_crs,
    sample_rows,
)
from kinsync.crs_axes import coordinate_metadata
from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import geodetic_to_ecef, quaternion_to_euler_rpy
from kinsync.io.quicklook import decimate, write_geojson_line, write_kml_line
from kinsync.io.table_writer import TableChunkWriter
from kinsync.io.trajectory import TimeScale, read_trajectory_file
from kinsync.progress import Progress, report
from kinsync.trajectory import Trajectory

__all__ = ["DEFAULT_MAX_VERTICES", "TABLE_SUFFIXES", "TrajectoryExport", "export_trajectory"]

TABLE_SUFFIXES = (".csv", ".parquet")
LINE_SUFFIXES = (".geojson", ".json", ".kml")
DEFAULT_MAX_VERTICES = 2000
"""Most vertices of a quick-look line when ``--max-vertices`` is not given."""
DEFAULT_CRS = "EPSG:4979"  # WGS 84 longitude, latitude, ellipsoidal height
BLOCK_RECORDS = 1 << 20
"""Records converted and written at a time: memory stays bounded on a long trajectory
(a 10 h, 200 Hz SBET took 6.5 GB written at once). Parquet's row groups hold as many
rows (pyarrow's default), so the file is the one a single write makes."""
STAGE_READING = "reading the trajectory"
STAGE_WRITING = "writing"


@dataclass(frozen=True)
class TrajectoryExport:
    """What `export_trajectory` wrote.

    Attributes
    ----------
    records : int
        Records read.
    written : int
        Rows (table) or vertices (line) written.
    time_scale : {"gps", "week"}
        Scale of the times (GPS time, or GPS seconds of week).
    t_start_s, t_end_s : float
        First and last record time (s).
    crs : CrsTransformInfo or None
        The transformation of a table output; None for a line (WGS 84 as read).
    """

    records: int
    written: int
    time_scale: TimeScale
    t_start_s: float
    t_end_s: float
    crs: CrsTransformInfo | None

    def as_document(self) -> dict[str, Any]:
        """The ``--json`` summary."""
        return {
            "records": self.records,
            "written": self.written,
            "time_scale": self.time_scale,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "crs": None if self.crs is None else self.crs.as_document(),
        }


def export_trajectory(
    path: Path,
    out_path: Path,
    *,
    crs: str | None = None,
    geoid: str | None = None,
    epoch_year: float | None = None,
    trajectory_crs: str = ECEF_WGS84,
    gps_week: int | None = None,
    max_vertices: int | None = None,
    progress: Progress | None = None,
) -> TrajectoryExport:
    """Write a trajectory as a table in ``crs`` or as a quick-look line (see the module).

    Parameters
    ----------
    path : Path
        Trajectory (CSV, SBET, POSPac / Inertial Explorer text export).
    out_path : Path
        ``.csv``/``.parquet`` (table), ``.geojson``/``.json`` or ``.kml`` (line).
    crs : str, optional
        Output CRS of a table (default ``EPSG:4979``, WGS 84 longitude/latitude/height);
        not for a line, which is WGS 84 longitude/latitude.
    geoid, epoch_year, trajectory_crs
        As for `kinsync.pipelines.georef.georeference_file` (tables only).
    gps_week : int, optional
        GPS week of seconds-of-week times (SBET, text exports).
    max_vertices : int, optional
        Most vertices of a line (default `DEFAULT_MAX_VERTICES`); not for a table, which
        keeps every record.
    progress : Progress, optional
        Told `STAGE_READING` (at 0), then the share of the records written
        (`STAGE_WRITING`; a table is converted and written `BLOCK_RECORDS` at a time).

    Raises
    ------
    InputError
        Unknown output suffix, CRS options given for a line, ``max_vertices`` for a
        table, a bad CRS, any error of the trajectory readers.
    """
    path, out_path = Path(path), Path(out_path)
    suffix = out_path.suffix.lower()
    if suffix not in TABLE_SUFFIXES + LINE_SUFFIXES:
        msg = (
            f"{out_path}: unknown output type {out_path.suffix!r}; use .csv or .parquet "
            "(a table in --crs), .geojson or .kml (a line for a quick look)"
        )
        raise InputError(msg)
    line = suffix in LINE_SUFFIXES
    if line and (crs is not None or geoid is not None or epoch_year is not None):
        msg = (
            f"{out_path}: GeoJSON and KML are WGS 84 longitude/latitude; --crs, --geoid and "
            "--epoch apply to a .csv or .parquet output"
        )
        raise InputError(msg)
    if not line and max_vertices is not None:
        msg = (
            f"{out_path}: --max-vertices thins a .geojson or .kml line; a .csv or .parquet "
            "table keeps every record: drop --max-vertices"
        )
        raise InputError(msg)
    if max_vertices is None:
        max_vertices = DEFAULT_MAX_VERTICES
    if line:
        decimate(2, max_vertices)  # a bad --max-vertices fails before reading
    report(progress, 0.0, STAGE_READING)
    traj, scale = read_trajectory_file(path, gps_week=gps_week)
    if scale == "week" and not line:
        warnings.warn(
            f"{out_path}: its t_s are GPS seconds of week ({traj.t_start_s:.10g} .. "
            f"{traj.t_end_s:.10g} s, as in {path}), but kinsync reads a trajectory table as "
            "GPS time since 1980: it will not match points or logs on GPS time; give "
            "--gps-week (the GPS week of the first record) to write GPS time",
            KinsyncWarning,
            stacklevel=2,
        )
    report(progress, 0.0, STAGE_WRITING)
    llh = traj.lat_lon_h
    if llh is None:  # the readers give geodetic trajectories
        msg = f"{path}: the trajectory has no geodetic positions"
        raise InputError(msg)
    if line:
        rows = decimate(len(traj), max_vertices)
        props = {"source": path.name, "records": len(traj), "vertices": len(rows)}
        props |= {"time_scale": scale, "t_start_s": traj.t_start_s, "t_end_s": traj.t_end_s}
        if suffix == ".kml":
            text = f"{len(traj)} records, t {traj.t_start_s} .. {traj.t_end_s} s ({scale})"
            write_kml_line(out_path, llh[rows, 1], llh[rows, 0], path.name, text)
        else:
            write_geojson_line(out_path, llh[rows, 1], llh[rows, 0], llh[rows, 2], props)
        return TrajectoryExport(len(traj), len(rows), scale, traj.t_start_s, traj.t_end_s, None)
    samples = list(sample_rows(len(traj)))
    sample_ecef_m = geodetic_to_ecef(llh[samples, 0], llh[samples, 1], llh[samples, 2])
    t_mid_s = 0.5 * (traj.t_start_s + traj.t_end_s)
    dated = scale == "gps" and t_mid_s >= PLAUSIBLE_DATE_GPS_S
    plan, info = plan_ecef_to_crs(
        crs or DEFAULT_CRS,
        geoid=geoid,
        epoch_year=epoch_year,
        source_crs=trajectory_crs,
        sample_ecef_m=sample_ecef_m,
        observation_epoch_year=gps_to_decimal_year(t_mid_s) if dated else None,
    )
    to_crs = crs_plan_transformer(plan)
    fields, metadata = coordinate_metadata(pyproj.CRS.from_user_input(crs or DEFAULT_CRS))
    n = len(traj)
    with TableChunkWriter(out_path, fields, metadata) as writer:
        for start in range(0, n, BLOCK_RECORDS):
            block = slice(start, min(start + BLOCK_RECORDS, n))
            columns = _table_block(traj, block, to_crs, path, crs or DEFAULT_CRS)
            writer.write({k: np.ascontiguousarray(v) for k, v in columns.items()})
            report(progress, block.stop / n, STAGE_WRITING)
    return TrajectoryExport(n, n, scale, traj.t_start_s, traj.t_end_s, info)


def _table_block(
    traj: Trajectory, rows: slice, to_crs: Any, path: Path, crs: str
) -> dict[str, FloatArray]:
    """The table's columns for records ``rows``, each of shape (len(rows),).

    Times (s), X, Y, Z in ``crs``, roll, pitch, yaw (deg), NED velocities (m/s) when
    the trajectory has them. Every value is computed record by record: a block holds
    the values the whole trajectory converted at once would.

    Raises
    ------
    InputError
        A record that does not convert to ``crs`` (the first one, by its 0-based row).
    """
    llh = traj.lat_lon_h
    assert llh is not None
    pos_ecef_m = geodetic_to_ecef(llh[rows, 0], llh[rows, 1], llh[rows, 2])
    xyz = pos_ecef_m if to_crs is None else to_crs(pos_ecef_m)
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0]) + int(rows.start)
        msg = (
            f"{path}: record {row} (t = {traj.t_s[row]!r} s) does not convert to "
            f"{crs}; is the CRS meant for this area?"
        )
        raise InputError(msg)
    rpy = np.degrees(quaternion_to_euler_rpy(traj.q_body_to_ned[rows]))
    columns = {"t_s": traj.t_s[rows], "X": xyz[:, 0], "Y": xyz[:, 1], "Z": xyz[:, 2]}
    columns |= {"roll_deg": rpy[:, 0], "pitch_deg": rpy[:, 1], "yaw_deg": rpy[:, 2]}
    if traj.vel_ned_m_s is not None:
        for j, name in enumerate(("vn_m_s", "ve_m_s", "vd_m_s")):
            columns[name] = traj.vel_ned_m_s[rows, j]
    return columns
