"""Method A from raw files: scanner-frame passes and an attitude log made into sphere passes.

`read_raw_passes` reads a pass folder's raw data (`kinsync.io.raw_passes`: the pass
index, ``raw/attitude.csv``, ``raw/mount.toml`` and one scanner-frame file per pass)
and georeferences every pass into the table-centred NED frame with the
latency-corrected attitude (`kinsync.georef.table`), ready for
`kinsync.latency.sphere.estimate_latency_sphere`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from kinsync._text import counted
from kinsync.errors import InputError
from kinsync.georef.table import georeference_attitude_only
from kinsync.io.mount_file import read_mount
from kinsync.io.passes import PASSES_CSV, read_pass_index
from kinsync.io.raw_passes import (
    RAW_ATTITUDE_CSV,
    RAW_DIR,
    RAW_MOUNT_TOML,
    raw_pass_name,
    read_raw_attitude,
    read_raw_pass,
)
from kinsync.latency.passes import SpherePass
from kinsync.latency.rate_check import (
    attitude_rate_deg_s,
    attitude_rate_offsets,
    attitude_rate_std_deg_s,
    judge_rates,
    mismatch_message,
)
from kinsync.progress import Progress, report
from kinsync.trajectory import Trajectory
from kinsync.trajectory_gaps import (
    GAP_ADVICE,
    TrajectoryGap,
    gap_index,
    gap_threshold_text,
    max_gap_for,
)

__all__ = [
    "read_raw_passes",
]


def _unreadable(
    t_s: float,
    attitude: Trajectory,
    corrected: Trajectory,
    attitude_path: Path,
    tau: float,
    max_gap_s: float | None,
) -> str:
    """Why the corrected attitude log cannot be read at ``t_s``: its span, or a gap."""
    read = f"read at the tag t + tau with latency tau = {tau!r} s"
    gaps = corrected.gaps(max_gap_s)
    k = int(gap_index(t_s, gaps))
    if k < 0:
        return (
            f"lies outside the attitude log {attitude_path} (tags [{attitude.t_start_s!r}, "
            f"{attitude.t_end_s!r}] s, {read}); "
            "kinsync does not extrapolate: extend the log or trim the pass"
        )
    gap = gaps[k]
    tags = TrajectoryGap(gap.t_start_s + tau, gap.t_end_s + tau)
    return (
        f"lies in a data gap of the attitude log {attitude_path}: no record between the tags "
        f"{tags.describe()}, one of its "
        f"{gap_threshold_text(max_gap_for(corrected.t_s, max_gap_s), given=max_gap_s is not None)}"
        f" ({read}); kinsync "
        f"does not interpolate across gaps: {GAP_ADVICE}, log the attitude without holes "
        "or trim the pass"
    )


def _check_attitude_rates(
    passes: list[SpherePass], corrected: Trajectory, attitude_path: Path, index_path: Path
) -> list[SpherePass]:
    """Raise when the attitude log turns otherwise than a pass's stated table rate.

    The IMU turns with the table: over each pass the log's rotation about the pass's
    axis is its table rate, with the same sign (`kinsync.latency.rate_check`), within
    `~kinsync.latency.rate_check.ATTITUDE_RATE_TOLERANCE`. Returns the passes, those the
    log judged marked with ``rate_checked_by``.
    """
    judged: list[bool] = []
    measured: list[tuple[str, float, float, float]] = []  # name, stated, shown, sigma

    def shown_by_attitude(p: SpherePass) -> float | None:
        assert p.t_s is not None  # raw passes have their times
        t0, t1 = float(p.t_s.min()), float(p.t_s.max())
        inside = (corrected.t_s >= t0) & (corrected.t_s <= t1)
        t = corrected.t_s[inside]
        R = corrected.interpolate(t).R_body_to_ned
        rate = attitude_rate_deg_s(t, R, p.axis_ned) if t.size >= 2 else None
        judged.append(rate is not None)
        if rate is not None:
            std = attitude_rate_std_deg_s(t, R, p.axis_ned)
            measured.append((Path(p.source).name, p.rate_deg_s, rate, std))
        return rate

    mismatches, n_checked = judge_rates(passes, shown_by_attitude)
    if mismatches:
        msg = f"{index_path} and {attitude_path}: " + mismatch_message(
            mismatches, n_checked, f"the attitude log {attitude_path.name}", points=False
        )
        raise InputError(msg)
    off = attitude_rate_offsets(measured, f"the attitude log {attitude_path.name}")
    if off:
        msg = f"{index_path} and {attitude_path}: {off}"
        raise InputError(msg)
    by = f"the attitude log {attitude_path.name}"
    return [replace(p, rate_checked_by=by) if j else p for p, j in zip(passes, judged, strict=True)]


def read_raw_passes(
    folder: Path,
    *,
    latency_s: float | None = None,
    max_gap_s: float | None = None,
    progress: Progress | None = None,
) -> list[SpherePass]:
    """Read and georeference the raw passes of a pass folder (Method A, raw input).

    Parameters
    ----------
    folder : Path
        Pass folder holding ``passes.csv`` (pass order, signed rates, axes) and the
        ``raw/`` sub-folder (``attitude.csv``, ``mount.toml`` and one
        ``t_s,x_m,y_m,z_m`` scanner-frame file per pass, named by `raw_pass_name`).
    latency_s : float, optional
        Latency tau (s) to correct the attitude for (SPEC section 1: tau > 0 reads the
        record tagged ``t + tau``); default the mount's ``latency_s``.
    max_gap_s : float, optional
        Longest attitude record interval (s) interpolated across; default
        `kinsync.trajectory_gaps.GAP_FACTOR` median record intervals.
    progress : Progress, optional
        Told after each pass is georeferenced (`kinsync.progress`).

    Returns
    -------
    list of SpherePass
        In the order of ``passes.csv``: points georeferenced into the table-centred
        NED frame (m) with their times (s); ``source`` is the raw pass file.

    Raises
    ------
    InputError
        Naming the file and line at fault: a missing folder, ``raw/`` folder,
        ``passes.csv``, ``attitude.csv``, ``mount.toml`` or raw pass file; missing
        columns; non-numeric or non-finite cells; attitude tags not increasing; an
        attitude that turns the other way than a pass's stated rate, or more than
        twice as fast or slow (`kinsync.latency.rate_check`: a wrong sign, rates in
        rad/s, angles in radians), or whose rate is more than 2 % off the stated one
        (gon/s, a miscalibrated controller); an
        empty pass; a point time outside the latency-corrected attitude span or inside
        one of its data gaps (`kinsync.trajectory_gaps`: a record interval longer than
        ``max_gap_s``; never interpolated across); a ``max_gap_s`` that is not positive.
    """
    folder = Path(folder)
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "not found"
        msg = f"{folder}: pass folder {what}; give the folder that holds {PASSES_CSV}"
        raise InputError(msg)
    index_path = folder / PASSES_CSV
    rows = read_pass_index(index_path)
    raw_dir = folder / RAW_DIR
    if not raw_dir.is_dir():
        msg = (
            f"{raw_dir}: raw folder not found; it must hold {RAW_ATTITUDE_CSV}, "
            f"{RAW_MOUNT_TOML} and one t_s,x_m,y_m,z_m file per pass"
        )
        raise InputError(msg)
    attitude_path = raw_dir / RAW_ATTITUDE_CSV
    attitude = read_raw_attitude(attitude_path)
    mount = read_mount(raw_dir / RAW_MOUNT_TOML)
    tau = mount.latency_s if latency_s is None else float(latency_s)
    if not np.isfinite(tau):
        msg = f"latency_s must be finite, got {latency_s!r}"
        raise InputError(msg)
    corrected = attitude.corrected_for_latency(tau)
    max_gap_for(corrected.t_s, max_gap_s)  # a bad threshold fails before any pass is read
    passes: list[SpherePass] = []
    for n_done, row in enumerate(rows):
        report(progress, n_done / len(rows), f"georeferencing raw pass {n_done + 1}")
        where = f"{index_path}: line {row.line}"
        path = raw_dir / raw_pass_name(row.file)
        try:
            t, xs, table = read_raw_pass(path)
            outside = ~corrected.contains(t, max_gap_s=max_gap_s)
            if np.any(outside):
                k = int(np.flatnonzero(outside)[0])
                raise InputError(
                    f"{path}: line {table.line_of_row(k)}: point time t_s={float(t[k])!r} "
                    f"({int(np.count_nonzero(outside))} point(s) in all) "
                    + _unreadable(float(t[k]), attitude, corrected, attitude_path, tau, max_gap_s)
                )
            passes.append(
                SpherePass(
                    source=str(path),
                    rate_deg_s=row.rate_deg_s,
                    points_ned_m=georeference_attitude_only(
                        t, xs, corrected, mount, max_gap_s=max_gap_s
                    ),
                    axis_ned=row.axis_ned,
                    t_s=t,
                )
            )
        except InputError as err:
            msg = f"{where}: {err}"
            raise InputError(msg) from err
    passes = _check_attitude_rates(passes, corrected, attitude_path, index_path)
    report(progress, 1.0, f"georeferenced {counted(len(rows), 'raw pass', 'raw passes')}")
    return passes
