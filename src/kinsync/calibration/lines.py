"""What the mount calibration works on: lines (or passes) of scanner-frame points.

A `ScanLine` is one line of a survey (or one pass over a target): the returns in the
scanner frame with their times, and the navigation solution that covers them. Lines
are the unit of the calibration's error model: trajectory errors are correlated
within a line and taken as independent between lines (the jackknife of
`kinsync.calibration.uncertainty` deletes one line at a time).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import coordinate_array, time_array
from kinsync.errors import InputError, PointValueError
from kinsync.frames import quaternion_to_euler_rpy, wrap_angle_rad
from kinsync.georef.kernel import MAX_SCANNER_RANGE_M
from kinsync.trajectory import Trajectory

__all__ = ["PASS_GAP_S", "ScanLine", "two_passes_in_a_line"]


@dataclass(frozen=True, eq=False)
class ScanLine(ReadOnlyArrays):
    """Scanner-frame returns of one line or pass, with their times and trajectory.

    Attributes
    ----------
    name : str
        What the line is called in messages and reports (a file name, ``line 3``).
    t_s : ndarray, shape (N,)
        Time of each return on the trajectory's time scale (s, GPS time), finite; float
        seconds as `kinsync._validate.time_array` takes them (datetime64, and float32
        beyond 16 s, are refused).
    xyz_scanner_m : ndarray, shape (N, 3)
        Returns in the scanner frame (m), finite and within
        ±`kinsync.georef.kernel.MAX_SCANNER_RANGE_M`, in a float dtype that holds
        0.1 mm (`kinsync._validate.coordinate_array`).
    trajectory : Trajectory
        Navigation solution at its own time tags (not corrected for latency): the
        calibration applies the latency it estimates (SPEC section 1).
    """

    name: str
    t_s: FloatArray
    xyz_scanner_m: FloatArray
    trajectory: Trajectory

    def __post_init__(self) -> None:
        name = str(self.name)
        t = time_array(self.t_s, f"line {name!r}: t_s")
        xyz = coordinate_array(self.xyz_scanner_m, f"line {name!r}: xyz_scanner_m")
        if t.ndim != 1 or t.size == 0:
            msg = f"line {name!r}: needs at least one return, got times of shape {t.shape}"
            raise InputError(msg)
        if xyz.shape != (t.size, 3):
            msg = f"line {name!r}: xyz_scanner_m must have shape ({t.size}, 3), got {xyz.shape}"
            raise InputError(msg)
        finite = np.column_stack([np.isfinite(t), np.isfinite(xyz)])
        bad = ~np.all(finite, axis=1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            field = ("t", "x", "y", "z")[int(np.flatnonzero(~finite[i])[0])]
            value = float(t[i]) if field == "t" else float(xyz[i, "xyz".index(field)])
            problem = f"{value!r} is not finite"
            count = int(np.count_nonzero(bad))
            msg = (
                f"line {name!r}: return at index {i} (0-based), {field}: {problem}; "
                f"{count} such return(s): drop or fix them"
            )
            raise PointValueError(
                msg, index=i, count=count, field=field, problem=problem, advice="drop or fix them"
            )
        within = np.abs(xyz) <= MAX_SCANNER_RANGE_M
        far = ~np.all(within, axis=1)
        if np.any(far):  # map coordinates (a georeferenced file) where scanner ones belong
            i = int(np.flatnonzero(far)[0])
            field = "xyz"[int(np.flatnonzero(~within[i])[0])]
            problem = (
                f"scanner coordinates {xyz[i].tolist()} m, beyond the "
                f"{MAX_SCANNER_RANGE_M:.0f} m any laser scanner reaches"
            )
            advice = "are these scanner-frame coordinates in metres?"
            count = int(np.count_nonzero(far))
            msg = (
                f"line {name!r}: return at index {i} (0-based), {field}: {problem}; "
                f"{count} such return(s): {advice}"
            )
            raise PointValueError(
                msg, index=i, count=count, field=field, problem=problem, advice=advice
            )
        if not isinstance(self.trajectory, Trajectory):
            msg = f"line {name!r}: trajectory must be a Trajectory"
            raise InputError(msg)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "t_s", readonly_array(t))
        object.__setattr__(self, "xyz_scanner_m", readonly_array(xyz))

    def __len__(self) -> int:
        return int(self.t_s.size)

    @property
    def t_start_s(self) -> float:
        """First return's time (s)."""
        return float(self.t_s.min())

    @property
    def t_end_s(self) -> float:
        """Last return's time (s)."""
        return float(self.t_s.max())

    def subset(self, index: ArrayLike) -> ScanLine:
        """The same line with only the returns ``index`` selects (mask or indices).

        Parameters
        ----------
        index : array_like
            A boolean mask of shape (N,), or integer indices (0-based) of the returns to
            keep, in the order wanted.

        Returns
        -------
        ScanLine
            Same name and trajectory; the selected times (s) and scanner-frame returns
            (m), shapes (M,) and (M, 3).

        Raises
        ------
        InputError
            ``index`` selects no return, is a mask of another length, or holds indices
            that are not whole numbers or lie beyond the line's returns.
        """
        idx = np.asarray(index)
        n = self.t_s.size
        if idx.dtype == np.bool_:
            if idx.shape != (n,):
                msg = f"line {self.name!r}: a mask of shape {idx.shape} for {n} returns"
                raise InputError(msg)
        elif idx.size and (
            idx.dtype.kind not in "iu" or idx.ndim != 1 or idx.min() < -n or idx.max() >= n
        ):
            msg = (
                f"line {self.name!r}: index must be a boolean mask of {n} values or 1-D "
                f"whole-number indices below {n}, got {idx.dtype} of shape {idx.shape}"
            )
            raise InputError(msg)
        elif idx.size == 0:
            idx = idx.astype(np.int64)
        return ScanLine(self.name, self.t_s[idx], self.xyz_scanner_m[idx], self.trajectory)


PASS_GAP_S = 5.0
"""A stop of a line's returns longer than this (s), with the heading turned by more than
`PASS_TURN_DEG` across it, is two passes in one file."""
PASS_TURN_DEG = 90.0


def two_passes_in_a_line(lines: list[ScanLine] | tuple[ScanLine, ...]) -> tuple[str, ...]:
    """Notes on the lines whose file holds two passes (a long stop, the heading turned).

    The jackknife takes each line as one independent unit: two passes in one file make
    one unit of two, with too few degrees of freedom and the passes' errors pooled.

    Returns
    -------
    tuple of str
        One note per such line, naming it, the stop and the turn.
    """
    notes = []
    for line in lines:
        t = np.sort(line.t_s)
        if t.size < 2:
            continue
        k = int(np.argmax(np.diff(t)))
        gap = float(t[k + 1] - t[k])
        ends = np.array([t[k], t[k + 1]])
        if gap <= PASS_GAP_S or not line.trajectory.contains(ends, max_gap_s=np.inf).all():
            continue
        q = line.trajectory.interpolate(ends, max_gap_s=np.inf).q_body_to_ned
        yaw = quaternion_to_euler_rpy(q)[:, 2]
        turn = abs(math.degrees(float(wrap_angle_rad(yaw[1] - yaw[0]))))
        if turn > PASS_TURN_DEG:
            notes.append(
                f"{line.name}: its returns stop for {gap:.1f} s (t {t[k]:.3f} -> "
                f"{t[k + 1]:.3f} s) and the heading turns {turn:.0f} deg across the stop: "
                "two passes in one file? The jackknife takes each file as one independent "
                "line, so give each pass its own file"
            )
    return tuple(notes)


MIN_LINE_SPREAD_M = 0.05
"""A line whose scanner-frame returns span less than this (m) on every axis is rejected."""
MIN_RETURNS_FOR_SPREAD = 100
"""Lines with fewer returns are not judged by their spread (3 returns of a pass that
missed its sphere are rejected as seeing no sphere)."""


def without_unspread_lines(
    lines: list[ScanLine], groups: Sequence[tuple[str, set[int]]] | None
) -> tuple[list[ScanLine], Sequence[tuple[str, set[int]]] | None, tuple[tuple[str, str], ...]]:
    """The lines whose returns spread in the scanner frame; the groups renumbered; the rest.

    A line of at least `MIN_RETURNS_FOR_SPREAD` returns that all sit within
    `MIN_LINE_SPREAD_M` of one another in the scanner frame (one point repeated: a corrupt
    or placeholder file) sees no surface: georeferenced,
    its returns only trace the trajectory, and they fell on patches the other lines see and
    pulled the solution (28 features cut to 16, roll 0.31 +- 0.04 deg moved to 0.13 +- 0.35).
    It is rejected with the reason, as a line that sees no feature is.

    Raises
    ------
    InputError
        Fewer than two lines are left.
    """
    xyz_spread = [float(np.max(np.ptp(line.xyz_scanner_m, axis=0))) for line in lines]
    # a handful of returns (a pass that missed its target) are left to the features' check
    keep = [
        i
        for i, s in enumerate(xyz_spread)
        if s >= MIN_LINE_SPREAD_M or len(lines[i]) < MIN_RETURNS_FOR_SPREAD
    ]
    rejected = tuple(
        (
            lines[i].name,
            (
                f"its {len(lines[i])} returns all lie within {xyz_spread[i] * 100:.2g} cm of "
                f"one another in the scanner frame (less than {MIN_LINE_SPREAD_M * 100:g} cm): "
                "one point repeated sees no surface; left out of the adjustment and of the "
                "jackknife (check the file)"
            ),
        )
        for i in range(len(lines))
        if i not in keep
    )
    if not rejected:
        return lines, groups, ()
    if len(keep) < 2:
        msg = (
            f"only {len(keep)} of the {len(lines)} lines have returns that spread in the "
            "scanner frame: "
            + "; ".join(f"line {n!r}: {r}" for n, r in rejected)
            + "; a calibration needs at least 2 overlapping lines"
        )
        raise InputError(msg)
    new_index = {old: new for new, old in enumerate(keep)}
    if groups is not None:
        groups = [
            (name, {new_index[i] for i in members if i in new_index})
            for name, members in groups
            if any(i in new_index for i in members)
        ]
    return [lines[i] for i in keep], groups, rejected
