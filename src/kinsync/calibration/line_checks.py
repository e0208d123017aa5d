"""Checks of the lines a mount calibration is given (`kinsync.calibration.calibrate_mount`).

Each refusal names the argument or the line and what to do: a mount that is not a
`kinsync.Mount`, an item of the lines that is not a `ScanLine`, fewer than two lines,
returns outside
their trajectory (with a hint when the time scales look mixed), returns in a data gap
of the trajectory, line names that are not unique.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from kinsync._text import shown_value
from kinsync._typing import FloatArray
from kinsync.calibration.lines import ScanLine
from kinsync.calibration.uncertainty import MIN_JACKKNIFE_GROUPS
from kinsync.errors import InputError
from kinsync.mount import Mount
from kinsync.trajectory_gaps import GAP_ADVICE, gap_index, gap_threshold_text, max_gap_for

__all__ = ["check_arguments", "check_lines"]


def check_arguments(lines: object, mount: object) -> list[ScanLine]:
    """The lines as a list, once they are `ScanLine` objects and ``mount`` a `Mount`.

    Parameters
    ----------
    lines : object
        What the caller gave as the lines: a sequence (or iterable) of `ScanLine`.
    mount : object
        What the caller gave as the mount.

    Returns
    -------
    list of ScanLine

    Raises
    ------
    InputError
        ``mount`` not a `Mount` (None, say), ``lines`` not iterable or an item not a
        `ScanLine` (naming its index).
    """
    if not isinstance(mount, Mount):
        msg = (
            f"mount: expected a kinsync.Mount, the mount the lines were acquired with "
            f"(kinsync.io.mount_file.read_mount reads one), got {shown_value(mount)}"
        )
        raise InputError(msg)
    if not isinstance(lines, Iterable):
        msg = f"lines: expected a sequence of ScanLine, got {shown_value(lines)}"
        raise InputError(msg)
    items: list[ScanLine] = []
    for i, line in enumerate(lines):
        if not isinstance(line, ScanLine):
            msg = (
                f"lines: item at index {i} (0-based) is a {type(line).__name__}, not a "
                "ScanLine (kinsync.calibration.ScanLine: a line's times, scanner-frame "
                "returns and trajectory; kinsync.pipelines.calibration.read_scan_lines "
                "reads them)"
            )
            raise InputError(msg)
        items.append(line)
    return items


def _check_gaps(line: ScanLine, tt: FloatArray, latency_s: float, max_gap_s: float | None) -> None:
    """Refuse returns of ``line`` whose navigation tags ``tt`` lie in a trajectory gap."""
    traj = line.trajectory
    gaps = traj.gaps(max_gap_s)
    k = gap_index(tt, gaps)
    in_gap = k >= 0
    if not np.any(in_gap):
        return
    hit = [gaps[int(i)] for i in np.unique(k[in_gap])]
    named = "; ".join(g.describe() for g in hit[:3])
    more = f"; and {len(hit) - 3} more" if len(hit) > 3 else ""
    msg = (
        f"line {line.name!r}: {int(np.count_nonzero(in_gap))} of {len(line)} returns (times "
        f"{float(tt[in_gap].min())!r} .. {float(tt[in_gap].max())!r} s, latency "
        f"{latency_s * 1e3:g} ms applied) lie in {len(hit)} data gap(s) of its trajectory "
        f"({named}{more}), "
        f"{gap_threshold_text(max_gap_for(traj.t_s, max_gap_s), given=max_gap_s is not None)}; "
        "kinsync "
        f"does not interpolate across gaps: {GAP_ADVICE}, or trim the lines"
    )
    raise InputError(msg)


def check_lines(
    lines: Sequence[ScanLine], latency_s: float, max_gap_s: float | None = None
) -> None:
    """Refuse lines a calibration cannot use.

    Parameters
    ----------
    lines : sequence of ScanLine
        The lines, each with its trajectory.
    latency_s : float
        The mount's latency (s), applied to the returns' times.
    max_gap_s : float, optional
        Longest trajectory record interval interpolated across (s); default from the
        median record interval (`kinsync.trajectory_gaps.max_gap_for`).

    Raises
    ------
    InputError
        Fewer than two lines, returns outside their trajectory or in one of its data
        gaps, names not unique.
    """
    if len(lines) < 2:
        msg = (
            f"{len(lines)} line given: a calibration needs at least 2 overlapping lines (or "
            f"passes), and {MIN_JACKKNIFE_GROUPS} or more for an honest standard deviation"
        )
        raise InputError(msg)
    names = [line.name for line in lines]
    for line in lines:
        traj = line.trajectory
        tt = line.t_s + latency_s
        outside = (tt < traj.t_start_s) | (tt > traj.t_end_s)
        if not np.any(outside):
            _check_gaps(line, tt, latency_s, max_gap_s)
            continue
        n_out = int(np.count_nonzero(outside))
        hint = ""
        if n_out == len(line):
            gap = float(np.median(tt)) - 0.5 * (traj.t_start_s + traj.t_end_s)
            if abs(gap) > 1e5:
                hint = (
                    " (they are far apart: mixed time scales? GPS seconds of week need "
                    "--gps-week; LAS adjusted standard time is GPS time - 1e9 s)"
                )
        msg = (
            f"line {line.name!r}: {n_out} of {len(line)} returns (times "
            f"{float(tt[outside].min())!r} .. {float(tt[outside].max())!r} s, latency "
            f"{latency_s * 1e3:g} ms applied) lie outside its trajectory "
            f"[{traj.t_start_s!r}, {traj.t_end_s!r}] s{hint}; kinsync does not extrapolate: "
            "give a trajectory that covers the lines or trim them"
        )
        raise InputError(msg)
    if len(set(names)) != len(names):
        msg = f"line names must be unique, got {names}"
        raise InputError(msg)
