"""What a georeferencing run says when its points' times miss the trajectory's span.

Points outside the span are counted by the chunks (`kinsync.pipelines.georef_chunks`);
this module turns the counts into words. When the times of the points that missed
show a time-scale mix-up (GPS seconds of week against GPS time since 1980, a LAS
header that says the wrong one, a wrong GPS week) the message says which, and what to
do; else it names the usual mix-ups. `OutsideTally` adds up the chunks' counts and
words the error or warning; nothing is printed here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from kinsync._unix_time import unix_offset_text
from kinsync.errors import InputError
from kinsync.georef.trajectory import GeorefRecords, GeorefTrajectory
from kinsync.io.gps_week import SECONDS_PER_WEEK, WEEK_SECONDS_MAX_S, WEEK_SECONDS_SLACK_S
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S, SOW_TRAJECTORY_ADVICE
from kinsync.io.trajectory import TimeScale, gps_week_needed_text
from kinsync.pipelines.georef_chunks import ChunkOutput
from kinsync.trajectory_gaps import GAP_ADVICE, gap_threshold_text

__all__ = ["GENERIC_TIME_ADVICE", "OutsideTally", "PointTimes", "scale_name", "time_scale_hint"]

_WEEK_MAX_S = WEEK_SECONDS_MAX_S  # beyond this, not seconds of week

GENERIC_TIME_ADVICE = (
    "check the time scales: GPS seconds of week against GPS time since 1980 (an SBET, or "
    "a LAS file in seconds of week, needs --gps-week), UTC against GPS time (18 s apart "
    "since 2017), or Unix time against GPS time (315964782 s apart since 2017)"
)
"""What to check when no particular mix-up can be told from the times."""


@dataclass(frozen=True)
class PointTimes:
    """How the points' times were put on the trajectory's time scale.

    Attributes
    ----------
    traj_scale : {"gps", "week"}
        The trajectory's time scale (`kinsync.io.trajectory.read_trajectory_file`).
    gps_week : int or None
        ``--gps-week``, when given.
    las_time_type : {"week", "adjusted_standard"} or None
        What a LAS/LAZ header says its ``gps_time`` is; None for a table.
    las_offset_s : float
        Added to a LAS file's stored ``gps_time`` (`kinsync.io.las.las_time_offset_s`).
    """

    traj_scale: TimeScale
    gps_week: int | None = None
    las_time_type: Literal["week", "adjusted_standard"] | None = None
    las_offset_s: float = 0.0

    @property
    def week_applies(self) -> bool:
        """Whether --gps-week could change how the times are read (and was not given)."""
        return self.gps_week is None and (self.traj_scale == "week" or self.las_time_type == "week")


def scale_name(scale: TimeScale) -> str:
    """The time scale in words."""
    return "GPS seconds of week" if scale == "week" else "GPS time since 1980"


def _range_text(t_min_s: float, t_max_s: float) -> str:
    if t_min_s == t_max_s:
        return f"{t_min_s:.10g} s"
    return f"{t_min_s:.10g} .. {t_max_s:.10g} s"


def time_scale_hint(
    times: PointTimes,
    t_min_s: float,
    t_max_s: float,
    traj_start_s: float,
    traj_end_s: float,
) -> str | None:
    """The time-scale mix-up the points' times show, in words; None if none is clear.

    Parameters
    ----------
    times : PointTimes
        How the points' times were read.
    t_min_s, t_max_s : float
        Earliest and latest time of the points that missed the span, on the
        trajectory's scale (a LAS file's offset added); NaN or infinite: no hint.
    traj_start_s, traj_end_s : float
        The trajectory's span, on the points' clock (latency applied).
    """
    if not (math.isfinite(t_min_s) and math.isfinite(t_max_s)):
        return None
    return unix_offset_text(
        (t_min_s, t_max_s), (traj_start_s, traj_end_s), "the points", "the trajectory"
    ) or _scale_hint(times, t_min_s, t_max_s, traj_start_s, traj_end_s)


def _scale_hint(
    times: PointTimes, t_min_s: float, t_max_s: float, traj_start_s: float, traj_end_s: float
) -> str | None:
    """`time_scale_hint` for finite times other than Unix time against GPS time."""
    traj_on_week = times.traj_scale == "week"
    if times.las_time_type is None:  # a table: its times are read as they are
        if (
            not traj_on_week
            and traj_start_s > _WEEK_MAX_S
            and t_min_s >= 0.0  # seconds of week are not negative
            and t_max_s <= _WEEK_MAX_S
        ):
            return (
                f"the point times ({_range_text(t_min_s, t_max_s)}) look like GPS seconds "
                "of week; a point table must carry the trajectory's time scale (GPS time "
                f"since 1980 here): add the GPS week times {SECONDS_PER_WEEK:.0f} s to them"
            )
        if traj_on_week and traj_end_s <= _WEEK_MAX_S and t_min_s > _WEEK_MAX_S:
            return gps_week_needed_text("GPS time (times beyond a week)", "week")
    else:
        stored_min, stored_max = t_min_s - times.las_offset_s, t_max_s - times.las_offset_s
        rollover = _rollover_hint(
            times,
            stored_min,
            stored_max,
            traj_start_s - times.las_offset_s,
            traj_end_s - times.las_offset_s,
        )
        if rollover is not None:
            return rollover
        if (
            times.las_time_type == "adjusted_standard"
            and not traj_on_week
            and stored_min >= 0.0
            and stored_max <= _WEEK_MAX_S
        ):
            return (
                f"the file's gps_time values ({_range_text(stored_min, stored_max)} as "
                "stored) look like GPS seconds of week, but its header says adjusted "
                f"standard GPS time (GPS time - {ADJUSTED_GPS_OFFSET_S:.0e} s, global "
                "encoding bit 0 set): "
                "clear the bit (with laspy: las.header.global_encoding.gps_time_type = "
                "laspy.header.GpsTimeType.WEEK_TIME, then write the file again) and give "
                "--gps-week"
            )
    return _week_trajectory_hint(times, t_min_s, t_max_s, traj_start_s, traj_end_s) or _week_hint(
        times, t_min_s, t_max_s, traj_start_s, traj_end_s
    )


def _rollover_hint(
    times: PointTimes, stored_min: float, stored_max: float, traj_lo: float, traj_hi: float
) -> str | None:
    """Points at one end of a GPS week, the trajectory at the other: a rollover.

    All on the stored seconds-of-week scale of a LAS file. A file whose times of week
    start again from 0 is refused up front when its first and last points show it
    (`kinsync.io.las.check_week_rollover`); this names it when they do not (points not
    in time order).
    """
    if times.las_time_type != "week":
        return None
    late = SECONDS_PER_WEEK - WEEK_SECONDS_SLACK_S
    if stored_max < WEEK_SECONDS_SLACK_S and traj_hi >= late:
        where = "at the start of the GPS week, the trajectory at its end"
    elif stored_min >= late and traj_lo < WEEK_SECONDS_SLACK_S:
        where = "at the end of the GPS week, the trajectory at its start"
    else:
        return None
    return (
        f"the points outside have GPS seconds of week {_range_text(stored_min, stored_max)} "
        f"as stored, {where}: the file crosses the GPS week rollover (its times start "
        "again from 0), and one GPS week cannot place both parts; store its times as "
        "adjusted standard GPS time, or split it where gps_time goes back to 0 and give "
        f"each part its own --gps-week{SOW_TRAJECTORY_ADVICE}"
    )


_LAST_WEEK = 16_536  # GPS week of 2297: beyond any survey time (1e10 s after 1980)


def _week_trajectory_hint(
    times: PointTimes, t_min_s: float, t_max_s: float, traj_start_s: float, traj_end_s: float
) -> str | None:
    """A trajectory table whose times are seconds of week, read as GPS time since 1980.

    `kinsync trajectory export` without --gps-week writes one from an SBET; --gps-week
    does not apply to a table, whose times are taken as they are.
    """
    if times.traj_scale == "week" or traj_end_s > _WEEK_MAX_S or t_min_s <= _WEEK_MAX_S:
        return None
    points_week = math.floor((0.5 * t_min_s + 0.5 * t_max_s) / SECONDS_PER_WEEK)
    shift_s = points_week * SECONDS_PER_WEEK
    if 0 <= points_week <= _LAST_WEEK and (
        t_max_s >= traj_start_s + shift_s and t_min_s <= traj_end_s + shift_s
    ):
        add = (
            f"the points lie in GPS week {points_week}: add {points_week} x "
            f"{SECONDS_PER_WEEK:.0f} = {shift_s:.0f} s to its t_s, or export it again with "
            f"kinsync trajectory export --gps-week {points_week}"
        )
    else:
        add = (
            f"add the GPS week x {SECONDS_PER_WEEK:.0f} s to its t_s, or export it again "
            "with kinsync trajectory export --gps-week"
        )
    return (
        f"the trajectory's times ({_range_text(traj_start_s, traj_end_s)}) look like GPS "
        "seconds of week, but a trajectory table (CSV) is read as GPS time since 1980 "
        f"(--gps-week does not apply to it), and the points carry GPS time: {add}"
    )


def _week_hint(
    times: PointTimes, t_min_s: float, t_max_s: float, traj_start_s: float, traj_end_s: float
) -> str | None:
    """A --gps-week that puts the points (or the trajectory) in the wrong week."""
    if times.gps_week is None or times.traj_scale == "week" or t_min_s <= _WEEK_MAX_S:
        return None
    # halves summed: t_min_s + t_max_s overflows to inf for times near 1e308
    traj_week = math.floor((0.5 * traj_start_s + 0.5 * traj_end_s) / SECONDS_PER_WEEK)
    points_week = math.floor((0.5 * t_min_s + 0.5 * t_max_s) / SECONDS_PER_WEEK)
    if not 0 <= points_week <= _LAST_WEEK:  # times no GPS week holds
        return None
    shift_s = (traj_week - points_week) * SECONDS_PER_WEEK
    if shift_s == 0.0 or t_max_s + shift_s < traj_start_s or t_min_s + shift_s > traj_end_s:
        return None
    return (
        f"the points lie in GPS week {points_week}, the trajectory in GPS week {traj_week}, "
        f"with the same seconds of week: check --gps-week {times.gps_week}"
    )


_GAPS_NAMED = 5  # gaps listed in a message


class OutsideTally:
    """Counts and time ranges of points outside the span, and of those in its gaps."""

    def __init__(self, times: PointTimes) -> None:
        self.times = times
        self.count = 0
        self.t_min_s = math.inf
        self.t_max_s = -math.inf
        self.gap_count = 0
        self.gap_t_min_s = math.inf
        self.gap_t_max_s = -math.inf

    def add(self, out: ChunkOutput) -> None:
        """Add one chunk's accounting."""
        if out.outside_count:
            self.count += out.outside_count
            self.t_min_s = min(self.t_min_s, out.outside_t_min_s)
            self.t_max_s = max(self.t_max_s, out.outside_t_max_s)
        if out.gap_count:
            self.gap_count += out.gap_count
            self.gap_t_min_s = min(self.gap_t_min_s, out.gap_t_min_s)
            self.gap_t_max_s = max(self.gap_t_max_s, out.gap_t_max_s)

    def none_within(self, points_in: int) -> bool:
        """Whether not one of ``points_in`` points lies within the trajectory's span."""
        return points_in > 0 and self.count - self.gap_count == points_in

    def gap_text(self, traj: GeorefTrajectory | GeorefRecords) -> str:
        """How many points fell in which gaps of the trajectory, for messages."""
        hit = [
            g for g in traj.gaps if g.t_end_s > self.gap_t_min_s and g.t_start_s < self.gap_t_max_s
        ]
        named = "; ".join(g.describe() for g in hit[:_GAPS_NAMED])
        more = f"; and {len(hit) - _GAPS_NAMED} more" if len(hit) > _GAPS_NAMED else ""
        return (
            f"{self.gap_count} point(s) with times {self.gap_t_min_s!r} .. "
            f"{self.gap_t_max_s!r} s fall in {len(hit)} gap(s) of the trajectory, "
            f"{gap_threshold_text(traj.max_gap_s, given=traj.max_gap_given)}: {named}{more}"
        )

    def describe(self, traj: GeorefTrajectory | GeorefRecords) -> str:
        """Which points could not be georeferenced and why: in gaps, outside the span."""
        outside = self.count - self.gap_count
        if self.gap_count == 0:
            what = f"{self.count} point(s) with times {self.t_min_s!r} .. {self.t_max_s!r} s lie"
        elif outside == 0:
            what = self.gap_text(traj)
        else:
            what = (
                f"{self.count} point(s) with times {self.t_min_s!r} .. {self.t_max_s!r} s cannot "
                f"be georeferenced: {self.gap_text(traj)}; {outside} other(s) lie"
            )
        if outside:
            what += f" outside the trajectory span [{traj.t_start_s!r}, {traj.t_end_s!r}] s"
        return what

    def hint(self, traj: GeorefTrajectory | GeorefRecords) -> str | None:
        """The time-scale mix-up the times outside the span show, if one is clear."""
        if self.count == self.gap_count:
            return None
        return time_scale_hint(self.times, self.t_min_s, self.t_max_s, traj.t_start_s, traj.t_end_s)

    def error(
        self, points_path: Path, traj: GeorefTrajectory | GeorefRecords, rejected: Path
    ) -> InputError:
        """The error of a run with points outside the span (``outside="error"``).

        ``rejected``: where ``--outside reject`` would write them.
        """
        no = "interpolate across a gap or extrapolate" if self.gap_count else "extrapolate"
        hint = self.hint(traj)
        scales = (
            f"({hint})"
            if hint is not None
            else "(--gps-week)"
            if self.times.week_applies
            else "(GPS seconds of week or GPS time since 1980, UTC or GPS time)"
        )
        msg = (
            f"{points_path}: {self.describe(traj)} (latency {traj.latency_s!r} s applied); "
            f"kinsync does not "
            f"{no}: give a trajectory that covers them, check the time scales {scales}, "
            + (f"{GAP_ADVICE}, " if self.gap_count else "")
            + f"or pass --outside reject to write them to {rejected}"
        )
        return InputError(msg)

    def span_error(self, points_path: Path, traj: GeorefTrajectory | GeorefRecords) -> InputError:
        """The error of a run none of whose points lies within the trajectory's span."""
        advice = self.hint(traj) or GENERIC_TIME_ADVICE
        msg = (
            f"{points_path}: no point lies within the trajectory's time span: the "
            f"{self.count} point(s) have times {self.t_min_s!r} .. {self.t_max_s!r} s, the "
            f"trajectory runs {traj.t_start_s!r} .. {traj.t_end_s!r} s "
            f"({scale_name(self.times.traj_scale)}, latency {traj.latency_s!r} s applied): "
            f"the two are on different time scales or do not overlap; {advice}. Nothing "
            "was written"
        )
        return InputError(msg)

    def warning(
        self, points_path: Path, traj: GeorefTrajectory | GeorefRecords, rejected: Path
    ) -> str:
        """The warning of a run that rejected points to ``rejected`` (``outside="reject"``)."""
        hint = self.hint(traj)
        latency = f" (latency {traj.latency_s!r} s applied)" if self.count > self.gap_count else ""
        why = "" if hint is None else f"; {hint}"
        return f"{points_path}: {self.describe(traj)}{latency}{why}: they went to {rejected}"
