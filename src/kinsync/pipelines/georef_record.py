"""The kinsync record of a georeferenced file: what `georeference_file` applied.

`georef_document` gathers it from the run's context (`kinsync.io.point_provenance`
says where each output format keeps it): the mount applied (after ``--latency-ms`` and
``--profiler-azimuth-deg``), the point file, the trajectory (its SHA-256: the very file),
the time options and how the times were read, the CRS and the transformation chosen.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kinsync.crs import CrsTransformInfo
from kinsync.io.point_provenance import file_document, point_document
from kinsync.io.trajectory import TimeScale
from kinsync.pipelines.georef_chunks import ChunkContext

__all__ = ["RecordedTimes", "georef_document"]


@dataclass(frozen=True)
class RecordedTimes:
    """How a run read the times, for its record.

    Attributes
    ----------
    trajectory : {"gps", "week"}
        The trajectory's times: GPS seconds, or seconds of the GPS week.
    gps_week : int or None
        The ``--gps-week`` given.
    las_gps_time : {"week", "adjusted_standard"} or None
        A LAS/LAZ input's ``gps_time``: seconds of week or adjusted standard GPS time
        (its global encoding); None for a table (``t_s``).
    """

    trajectory: TimeScale
    gps_week: int | None
    las_gps_time: str | None


def georef_document(
    ctx: ChunkContext,
    crs: CrsTransformInfo,
    trajectory_path: Path,
    mount_file: Path | None,
    times: RecordedTimes,
) -> dict[str, Any] | None:
    """The kinsync record of a georeferencing run (`kinsync.io.point_provenance`).

    None for a CSV output (``ctx.csv_text``), which has nowhere to keep it: the files are
    not read again (a 10 h SBET of 1 GB takes 1.4 s to hash).

    Parameters
    ----------
    ctx : ChunkContext
        The run's context: its point file, trajectory, mount (the one applied),
        position interpolation, CRS plan and ``outside`` policy.
    crs : CrsTransformInfo
        The transformation chosen to the output CRS.
    trajectory_path : Path
        The trajectory file read.
    mount_file : Path or None
        The mount file ``ctx.mount`` was read from (None: built in Python).
    times : RecordedTimes
        How the times were read.

    Returns
    -------
    dict or None
        `kinsync.io.point_provenance.point_document` with ``points`` (path),
        ``trajectory`` (path, bytes, SHA-256, its CRS, the longest interval bridged
        ``max_gap_s``, ``position``), ``time`` (the trajectory's time scale,
        ``gps_week``, the LAS ``gps_time`` kind and the offset added to it),
        ``crs`` (the CRS as given, then `CrsTransformInfo.as_document`) and ``outside``.
    """
    if ctx.csv_text:
        return None
    sections = {
        "points": {"path": str(ctx.source.path)},
        "trajectory": file_document(Path(trajectory_path))
        | {"crs": crs.source, "max_gap_s": ctx.traj.max_gap_s, "position": ctx.position},
        "time": {
            "trajectory": times.trajectory,
            "gps_week": times.gps_week,
            "points": "t_s" if times.las_gps_time is None else f"gps_time {times.las_gps_time}",
            "las_time_offset_s": ctx.source.las_time_offset_s,
        },
        "crs": {"requested": ctx.crs.crs, **crs.as_document()},
        "outside": ctx.outside,
    }
    return point_document("georef", ctx.mount, mount_file, sections)
