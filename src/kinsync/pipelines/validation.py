"""Validation of georeferenced cloud files (SPEC section 7).

A cloud is what ``kinsync georef`` writes (LAS/LAZ, or CSV/Parquet with ``X,Y,Z``).
`control_points_file` streams it and keeps only the points near a control point, then
runs `kinsync.validation.control_points.validate_control_points`; `flatness_file`
keeps the points inside a box and runs `kinsync.validation.flatness.fit_wall`. Memory
is bounded by the kept points, not the cloud.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kinsync._typing import FloatArray
from kinsync.crs import crs_to_ecef_transformer
from kinsync.errors import InputError, KinsyncError
from kinsync.io.cloud import CloudExtent, check_finite_chunk, cloud_crs, iter_cloud
from kinsync.io.control_points import read_control_points
from kinsync.io.sanity import require_file
from kinsync.io.trajectory import read_trajectory_file
from kinsync.trajectory_gaps import max_gap_for
from kinsync.validation.control_report import ControlPointReport, validate_control_points
from kinsync.validation.flatness import Box, FlatnessResult, fit_wall, select_box
from kinsync.validation.scan_geometry import check_cloud_view, check_visit_ranges
from kinsync.validation.targets import (
    CentreMethod,
    CloudPoints,
    check_extraction_options,
    nearest_control,
)

_VIEW_SAMPLE = 256  # cloud points per chunk kept for check_cloud_view

__all__ = [
    "control_points_file",
    "flatness_file",
]


def control_points_file(
    cloud_path: Path,
    control_path: Path,
    trajectory_path: Path,
    *,
    crs: str | None = None,
    search_radius_m: float = 0.5,
    min_intensity: float | None = None,
    centre: CentreMethod = "tukey",
    target_radius_m: float | None = None,
    min_points: int = 10,
    level: float = 0.99,
    gps_week: int | None = None,
    chunk_points: int = 1_000_000,
    max_gap_s: float | None = None,
) -> ControlPointReport:
    """Validate a georeferenced cloud file against a control-point file.

    Streams the cloud and keeps only the points within ``search_radius_m`` of a control
    point, then runs `validate_control_points`.

    Parameters
    ----------
    cloud_path : Path
        ``kinsync georef`` output: ``.csv``/``.parquet`` with ``X,Y,Z`` (in ``crs``),
        ``t_s`` and ``intensity``; or ``.las``/``.laz`` (``gps_time``, ``intensity``).
    control_path : Path
        Control CSV (`kinsync.io.control_points`).
    trajectory_path : Path
        Trajectory CSV or SBET (`kinsync.georef.read_trajectory_file`).
    crs : str, optional
        The cloud's CRS; default EPSG:4978, or the CRS a LAS file carries.
    gps_week : int, optional
        GPS week, for LAS seconds-of-week times or an SBET.
    chunk_points : int
        Points read per chunk (bounds memory).
    max_gap_s : float, optional
        Longest trajectory record interval (s) interpolated across; visits inside a
        longer one (a data gap) are missing. Default
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals.
    search_radius_m, min_intensity, centre, target_radius_m, min_points, level
        As in `validate_control_points`.

    Returns
    -------
    ControlPointReport

    Raises
    ------
    InputError
        Unreadable files, missing columns, unknown CRS, bad options, no point near any
        control point.
    """
    cloud_path = Path(cloud_path)
    check_extraction_options(
        search_radius_m, min_intensity, centre, target_radius_m, min_points, 1.0
    )
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    control = read_control_points(Path(control_path))
    trajectory, traj_scale = read_trajectory_file(Path(trajectory_path), gps_week=gps_week)
    max_gap_for(trajectory.t_s, max_gap_s)  # a bad threshold fails before the cloud is read
    require_file(cloud_path, "point cloud")
    to_ecef = crs_to_ecef_transformer(crs_text := cloud_crs(cloud_path, crs))
    pos_parts: list[FloatArray] = []
    t_parts: list[FloatArray] = []
    i_parts: list[FloatArray] = []
    chunk_medians: list[float] = []  # the survey's typical intensity, chunk by chunk
    extent = CloudExtent()
    nearest = (np.inf, "")  # (distance (m) from a chunk's mean point, control point name)
    view: list[FloatArray] = []  # a sample of the cloud (t_s, X, Y, Z), for check_cloud_view
    done = 0
    for xyz, t, inten in iter_cloud(
        cloud_path, chunk_points, need_time=True, traj_scale=traj_scale, gps_week=gps_week
    ):
        assert t is not None
        assert inten is not None
        check_finite_chunk(cloud_path, xyz, done, t_s=t, intensity=inten)
        done += xyz.shape[0]
        extent.add(xyz, t)
        if inten.size:
            chunk_medians.append(float(np.median(inten)))
        ecef = xyz if to_ecef is None else to_ecef(xyz)
        keep = nearest_control(ecef, control, search_radius_m) >= 0
        if ecef.shape[0]:  # how far the cloud lies from the control, for the message below
            gap = np.linalg.norm(control.pos_ecef_m - ecef.mean(axis=0), axis=1)
            if float(gap.min()) < nearest[0]:
                nearest = (float(gap.min()), control.names[int(np.argmin(gap))])
        pos_parts.append(ecef[keep])
        view.append(_view_sample(t, ecef))
        t_parts.append(t[keep])
        i_parts.append(inten[keep])
    pos = np.concatenate(pos_parts) if pos_parts else np.empty((0, 3))
    if pos.shape[0] == 0:
        msg = (
            f"{cloud_path}: no point within {search_radius_m:g} m of any of the "
            f"{len(control)} control points of {control_path}; {extent.text()} ({crs_text})"
            f"{_distance_text(nearest)}; check --crs, the control file and --search-radius-m"
        )
        raise InputError(msg)
    cloud = CloudPoints(pos, np.concatenate(t_parts), np.concatenate(i_parts))
    try:
        report = validate_control_points(
            cloud,
            control,
            trajectory,
            search_radius_m=search_radius_m,
            min_intensity=min_intensity,
            centre=centre,
            target_radius_m=target_radius_m,
            min_points=min_points,
            level=level,
            background_intensity=float(np.median(chunk_medians)),
            max_gap_s=max_gap_s,
            cloud_span_s=(extent.t_first_s, extent.t_last_s),
        )
    except KinsyncError as err:
        msg = f"{cloud_path}: {err}"
        raise InputError(msg) from err
    # a trajectory of another place or height: the time error would collapse to zero
    name = f"{trajectory_path} against {cloud_path}"
    check_visit_ranges(report.differences, name)
    sample = np.concatenate(view)  # never empty: the cloud had points near the control
    check_cloud_view(trajectory, sample[:, 1:], sample[:, 0], name)
    return report


def _view_sample(t_s: FloatArray, pos_ecef_m: FloatArray) -> FloatArray:
    """At most `_VIEW_SAMPLE` rows ``(t_s, X, Y, Z)`` spread over a chunk, shape (K, 4)."""
    step = max(1, pos_ecef_m.shape[0] // _VIEW_SAMPLE)
    out: FloatArray = np.column_stack([t_s, pos_ecef_m])[::step][:_VIEW_SAMPLE]
    return out


def flatness_file(
    cloud_path: Path,
    box: Box,
    *,
    crs: str | None = None,
    level: float = 0.99,
    outlier_k: float = 4.0,
    min_bow_m: float = 0.0,
    chunk_points: int = 1_000_000,
) -> FlatnessResult:
    """Select the points of a cloud file inside a box (cloud CRS) and run `fit_wall`.

    Parameters
    ----------
    cloud_path : Path
        ``.csv``/``.parquet`` with ``X,Y,Z`` or ``.las``/``.laz``.
    box : Box
        ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in the cloud's CRS.
    crs : str, optional
        The cloud's CRS; default EPSG:4978, or the CRS a LAS file carries.
    level, outlier_k, min_bow_m
        As in `fit_wall`.
    chunk_points : int
        Points read per chunk.

    Returns
    -------
    FlatnessResult

    Raises
    ------
    InputError
        Unreadable file, missing columns, unknown CRS, an empty box (with the cloud's
        extent), too few or degenerate points.
    """
    cloud_path = Path(cloud_path)
    if chunk_points < 1:
        msg = f"--chunk-points must be >= 1, got {chunk_points}"
        raise InputError(msg)
    require_file(cloud_path, "point cloud")
    crs_text = cloud_crs(cloud_path, crs)
    to_ecef = crs_to_ecef_transformer(crs_text)
    parts: list[FloatArray] = []
    extent = CloudExtent()
    done = 0
    for xyz, _, _ in iter_cloud(cloud_path, chunk_points, need_time=False):
        check_finite_chunk(cloud_path, xyz, done)
        done += xyz.shape[0]
        extent.add(xyz)
        parts.append(xyz[select_box(xyz, box)])
    sel = np.concatenate(parts) if parts else np.empty((0, 3))
    box_text = ",".join(repr(float(v)) for v in box)  # every digit: a tiny box reads as one
    if sel.shape[0] == 0:
        msg = (
            f"{cloud_path}: no point inside the box {box_text}; {extent.text()} ({crs_text}): "
            f"give --box in the cloud's CRS ({crs_text}) and units, inside that extent (not "
            "latitude and longitude unless the cloud's CRS is geographic)"
        )
        raise InputError(msg)
    try:
        return fit_wall(
            sel if to_ecef is None else to_ecef(sel),
            level=level,
            outlier_k=outlier_k,
            min_bow_m=min_bow_m,
        )
    except KinsyncError as err:
        msg = f"{cloud_path}, box {box_text}: {err}"
        raise InputError(msg) from err


def _distance_text(nearest: tuple[float, str]) -> str:
    """``nearest`` (distance (m) from the cloud, control point name) in words, or ""."""
    distance_m, name = nearest
    if not np.isfinite(distance_m):
        return ""
    far = f"{distance_m / 1000:,.0f} km" if distance_m >= 10_000 else f"{distance_m:,.1f} m"
    return f", about {far} from the nearest control point ({name})"
