"""One georeferenced pass of a rotating table over a sphere: the `SpherePass` container."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray
from kinsync._validate import finite_number, finite_vector, time_array
from kinsync.errors import InputError
from kinsync.time_spans import SAME_TIME_SHARE, recorded_together

__all__ = ["SAME_TIME_SHARE", "SpherePass", "check_distinct_passes", "pass_sequence"]


@dataclass(frozen=True, eq=False)
class SpherePass(ReadOnlyArrays):
    """Points of one pass, georeferenced in the table-centred NED frame.

    Parameters
    ----------
    source : str
        Where the pass came from (file path or label), for messages.
    rate_deg_s : float
        Signed table rate from the table controller (deg/s), a number (not an array):
        positive is right-handed
        about ``axis_ned`` (about +Down: clockwise seen from above). Non-zero.
    axis_ned : tuple of 3 float
        Rotation axis, table-centred NED; normalised on construction. Default +Down.
    points_ned_m : array_like, shape (N, 3)
        Georeferenced points, table-centred NED (m); may include clutter.
    t_s : array_like, shape (N,), optional
        Point times (s, float64: not datetime64), finite, when the file has them.
    rate_checked_by : str, optional
        What confirmed the stated rate's sign and unit other than the points, in words
        (the raw-pass reader sets "the attitude log NAME" when the log turned with it);
        `kinsync.latency.rate_check.check_pass_rates` counts such a pass as checked.
    """

    source: str
    rate_deg_s: float
    points_ned_m: FloatArray
    axis_ned: tuple[float, float, float] = (0.0, 0.0, 1.0)
    t_s: FloatArray | None = None
    rate_checked_by: str | None = None

    def __post_init__(self) -> None:
        rate = finite_number(self.rate_deg_s, f"{self.source}: rate_deg_s")
        if rate == 0.0:
            msg = (
                f"{self.source}: rate_deg_s is 0; a pass at rest carries no latency "
                "information (give the signed table rate)"
            )
            raise InputError(msg)
        detail = " (N, E, D), non-zero"
        axis = finite_vector(self.axis_ned, 3, f"{self.source}: axis_ned", detail)
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            msg = f"{self.source}: axis_ned must be a non-zero 3-vector, got {self.axis_ned!r}"
            raise InputError(msg)
        try:
            pts = np.asarray(self.points_ned_m, dtype=np.float64)
        except (TypeError, ValueError) as err:  # text, a ragged list of rows
            msg = f"{self.source}: points must be numbers, shape (N, 3) ({err})"
            raise InputError(msg) from err
        if pts.ndim != 2 or pts.shape[1] != 3:
            msg = f"{self.source}: points must have shape (N, 3), got {pts.shape}"
            raise InputError(msg)
        finite = np.all(np.isfinite(pts), axis=1)
        if not np.all(finite):
            row = int(np.flatnonzero(~finite)[0])
            msg = f"{self.source}: non-finite coordinate at point index {row} (0-based)"
            raise InputError(msg)
        pts = pts.copy()
        pts.setflags(write=False)
        object.__setattr__(self, "rate_deg_s", rate)
        object.__setattr__(self, "axis_ned", tuple(float(v) for v in axis / norm))
        object.__setattr__(self, "points_ned_m", pts)
        if self.t_s is not None:
            t = time_array(self.t_s, f"{self.source}: t_s").copy()
            if t.shape != (pts.shape[0],):
                msg = f"{self.source}: t_s has shape {t.shape}, expected ({pts.shape[0]},)"
                raise InputError(msg)
            bad = ~np.isfinite(t)
            if np.any(bad):
                row = int(np.flatnonzero(bad)[0])
                msg = (
                    f"{self.source}: t_s: time at point index {row} (0-based) is not finite "
                    f"({t[row]!r}); drop the point or fix its time"
                )
                raise InputError(msg)
            t.setflags(write=False)
            object.__setattr__(self, "t_s", t)

    @property
    def rate_vector_ned_rad_s(self) -> FloatArray:
        """Signed rate vector ``omega * axis`` (rad/s, NED), shape (3,)."""
        return math.radians(self.rate_deg_s) * np.asarray(self.axis_ned)

    @property
    def n_points(self) -> int:
        """Number of points (sphere and clutter)."""
        return int(self.points_ned_m.shape[0])


def check_distinct_passes(passes: Sequence[SpherePass]) -> Sequence[SpherePass]:
    """Refuse one pass given twice (a copy, a symbolic or hard link under another name).

    Counted twice, it shrinks the latency's sigma by up to sqrt(2) and pulls the
    estimate towards itself. Two passes with times are the same when their spans overlap
    by more than `SAME_TIME_SHARE` of the shorter (one scanner records one pass at a
    time); without times, when they hold the same points (in any order).

    Parameters
    ----------
    passes : sequence of SpherePass
        The passes.

    Returns
    -------
    sequence of SpherePass
        ``passes``, checked.

    Raises
    ------
    InputError
        Naming both passes.
    """
    seen: dict[bytes, str] = {}
    for a, first in enumerate(passes):
        for second in passes[a + 1 :]:
            if first.t_s is None or second.t_s is None or not (first.n_points and second.n_points):
                continue
            a0, a1 = float(first.t_s.min()), float(first.t_s.max())
            b0, b1 = float(second.t_s.min()), float(second.t_s.max())
            if recorded_together((a0, a1), (b0, b1)):
                _refuse_twice(
                    first,
                    second,
                    f"were recorded at the same time ({a0!r} .. {a1!r} s and {b0!r} .. "
                    f"{b1!r} s): one scanner records one pass at a time",
                )
        pts = first.points_ned_m
        key = pts[np.lexsort(pts.T[::-1])].tobytes()
        if key in seen:
            other = next(p for p in passes if p.source == seen[key])
            _refuse_twice(other, first, f"hold the same {first.n_points} points")
        seen[key] = first.source
    return passes


def _refuse_twice(first: SpherePass, second: SpherePass, why: str) -> None:
    msg = (
        f"passes {first.source} and {second.source} {why}: this is one pass given twice "
        "(a copy, or a link under another name), which would count twice and shrink the "
        "latency's sigma; list each pass once in passes.csv"
    )
    raise InputError(msg)


def pass_sequence(passes: Iterable[SpherePass]) -> tuple[SpherePass, ...]:
    """``passes`` as a tuple (a generator is read once), each checked to be a `SpherePass`.

    Parameters
    ----------
    passes : iterable of SpherePass
        What a caller gave as the passes.

    Raises
    ------
    InputError
        A string, a single pass, something not iterable, or an item that is not a
        `SpherePass` (named by its index).
    """
    if isinstance(passes, (str, bytes, SpherePass)) or not isinstance(passes, Iterable):
        msg = f"passes: expected a sequence of SpherePass, got {type(passes).__name__}"
        raise InputError(msg)
    out = tuple(passes)
    for i, p in enumerate(out):
        if not isinstance(p, SpherePass):
            msg = f"passes: item at index {i} (0-based) is a {type(p).__name__}, not a SpherePass"
            raise InputError(msg)
    return out
