"""Each pass must turn the way its stated table rate says (Method A, SPEC section 2).

A wrong sign of a pass's rate (or a table controller whose sign convention is the
opposite of kinsync's), rates in rad/s given as deg/s, or points exported in another
frame (ENU for NED) do not stop the estimator: they flip or scale the latency. Each is
seen by comparing the stated rate with the rate the data themselves show:

- the points of a pass: a profile scanner on the table axis sweeps the scene with the
  table, so in the table-centred frame the azimuth of its returns about the rotation
  axis turns at the table rate, the same sign as the stated rate (right-handed about
  the axis: about +Down, clockwise seen from above). `points_azimuth_rate_deg_s` fits
  that azimuth against the point times;
- the attitude log (raw input): its rotation about the axis over the pass
  (`attitude_rate_deg_s`), also the table rate with the same sign.

A rate the data show with the other sign, or more than a factor `RATE_RATIO_LIMIT` off,
is a mismatch (`RateMismatch`); `mismatch_message` says which, and when the mismatches
all look like one unit mix-up (rad/s for deg/s, or an attitude in radians), says so.
The check is loose on purpose: the latency itself moves the points by far less.
The attitude log measures each pass's rate far better (to about 0.01 %): against it a
stated rate off by more than `ATTITUDE_RATE_TOLERANCE` is refused as well
(`attitude_rate_offsets`), since a rate scale error scales the latency by the same factor
(gon/s given as deg/s: 11 %).

Passes whose rates no data could check (no point times, points that do not sweep) are
estimated all the same: `estimate_latency_sphere` then issues a
`RatesUncheckedWarning` saying so (`warn_unchecked_rates`), as the command line does.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._text import counted
from kinsync._typing import FloatArray
from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import wrap_angle_rad
from kinsync.latency.passes import SpherePass

__all__ = [
    "ATTITUDE_RATE_TOLERANCE",
    "MIN_SWEEP_CORRELATION",
    "RATE_RATIO_LIMIT",
    "RateMismatch",
    "RatesUncheckedWarning",
    "attitude_rate_deg_s",
    "attitude_rate_offsets",
    "attitude_rate_std_deg_s",
    "check_pass_rates",
    "judge_rates",
    "mismatch_message",
    "points_azimuth_rate_deg_s",
    "rate_check_counts",
    "rate_mismatch",
    "unchecked_rates_text",
    "warn_unchecked_rates",
]

ATTITUDE_RATE_TOLERANCE = 0.02
"""A stated rate off the attitude log's by more than this fraction (and by more than
`_OFFSET_SIGMAS` of the log's rate sigma) is refused: the log's rate of a simulated pass
scatters by about 0.01 %, a table's regulation by about 0.05 %."""

_OFFSET_SIGMAS = 5.0
_GON_PER_DEG = 400.0 / 360.0

RATE_RATIO_LIMIT = 2.0
"""A shown rate within this factor of the stated one (same sign) agrees with it."""

MIN_SWEEP_CORRELATION = 0.5
"""The points' azimuth must follow their time at least this closely (|correlation|) for
their rate to be judged: a scanner that does not sweep with the table (a spinning
multi-beam head, points without meaningful times) is not judged."""

_MIN_POINTS = 10
_MIN_CONCENTRATION = 0.5
"""Least mean resultant length of the points' directions about the axis to judge them."""
_MIN_AXIS_SINE = 0.5
"""Half the points must be seen at least 30 deg off the axis (from the table centre)."""
"""Least mean resultant length of the points' directions about the axis to judge them."""
_SHOWN_MAX = 3
_DEG_PER_RAD = math.degrees(1.0)
_UNIT_TOLERANCE = 1.3
"""A ratio within this factor of 57.3 (or 1/57.3) reads as a radian/degree mix-up."""


@dataclass(frozen=True)
class RateMismatch:
    """A pass whose data turn otherwise than its stated table rate.

    Attributes
    ----------
    source : str
        The pass (its file), as the message names it.
    stated_deg_s : float
        The signed table rate given for the pass (deg/s).
    shown_deg_s : float
        The signed rate about the pass's axis that its data show (deg/s).
    """

    source: str
    stated_deg_s: float
    shown_deg_s: float

    @property
    def ratio(self) -> float:
        """``shown / stated`` (negative: opposite signs)."""
        return self.shown_deg_s / self.stated_deg_s

    def text(self) -> str:
        """``pass_020.csv: stated +18 deg/s, shows -17.5 deg/s``."""
        return (
            f"{self.source}: stated {self.stated_deg_s:+.4g} deg/s, "
            f"shows {self.shown_deg_s:+.3g} deg/s"
        )


def rate_mismatch(stated_deg_s: float, shown_deg_s: float) -> bool:
    """True when ``shown_deg_s`` has the other sign or is off by more than `RATE_RATIO_LIMIT`."""
    ratio = shown_deg_s / stated_deg_s
    return not 1.0 / RATE_RATIO_LIMIT <= ratio <= RATE_RATIO_LIMIT


def _axis_basis(axis_ned: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit ``u`` perpendicular to the axis and ``v = axis x u``: azimuth = atan2(v, u).

    The azimuth grows with a right-handed turn about the axis (about +Down: u = North,
    v = East, clockwise seen from above).
    """
    a = axis_ned / np.linalg.norm(axis_ned)
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = helper - (helper @ a) * a
    u /= np.linalg.norm(u)
    return u, np.cross(a, u)


def points_azimuth_rate_deg_s(
    points_ned_m: FloatArray, t_s: FloatArray, axis_ned: tuple[float, float, float]
) -> float | None:
    """Rate at which the points' azimuth about the table axis turns with time (deg/s).

    Parameters
    ----------
    points_ned_m : ndarray, shape (N, 3)
        Points of one pass, table-centred frame (m).
    t_s : ndarray, shape (N,)
        Their times (s).
    axis_ned : tuple of 3 float
        The table's rotation axis (unit vector).

    Returns
    -------
    float or None
        Signed slope (deg/s) of the least-squares line of azimuth against time,
        right-handed about ``axis_ned``; None when it says nothing: most points seen
        within 30 deg of the axis from the table centre (an axis pointing into the
        scene, which the estimator reports as unobservable), fewer than 10 points away
        from the axis, points spread all around the axis (mean resultant
        length of their directions below 0.5: an axis pointing into the scene), no time
        span, or azimuth and time correlated less than `MIN_SWEEP_CORRELATION`.
        Points more than 90 deg from the pass's mean direction (the far side of a full
        profile) are left out.
    """
    u, v = _axis_basis(np.asarray(axis_ned, dtype=np.float64))
    pu, pv = points_ned_m @ u, points_ned_m @ v
    radial = np.hypot(pu, pv)
    distance = np.linalg.norm(points_ned_m, axis=1)
    seen_off_axis = radial > _MIN_AXIS_SINE * distance
    if np.count_nonzero(seen_off_axis) < 0.5 * radial.size:
        return None  # the axis points into the scene: the turn hardly moves the azimuth
    near = radial > 0.05 * float(np.median(radial)) if radial.size else radial > 0
    if np.count_nonzero(near) < _MIN_POINTS:
        return None
    pu, pv, radial, t = pu[near], pv[near], radial[near], t_s[near]
    sum_v, sum_u = float(np.sum(pv / radial)), float(np.sum(pu / radial))
    if math.hypot(sum_u, sum_v) < _MIN_CONCENTRATION * radial.size:
        return None  # points all around the axis (it points into the scene): no azimuth
    mean_dir = math.atan2(sum_v, sum_u)
    az = wrap_angle_rad(np.arctan2(pv, pu) - mean_dir)
    front = np.abs(az) < 0.5 * math.pi
    az, t = az[front], t[front]
    if az.size < _MIN_POINTS or float(np.ptp(t)) <= 0.0 or float(np.ptp(az)) <= 0.0:
        return None
    tc = t - t.mean()
    azc = az - az.mean()
    corr = float(tc @ azc / math.sqrt(float(tc @ tc) * float(azc @ azc)))
    if abs(corr) < MIN_SWEEP_CORRELATION:
        return None
    return math.degrees(float(tc @ azc / (tc @ tc)))


def _axis_turns_rad(R_body_to_ned: FloatArray, axis_ned: tuple[float, float, float]) -> FloatArray:
    """The turn between consecutive records (``R_k+1 R_k^T``) about the axis (rad)."""
    step = np.einsum("kij,klj->kil", R_body_to_ned[1:], R_body_to_ned[:-1])
    # Small turns: the rotation vector from the skew part (exact enough between records).
    skew_part = 0.5 * (step - np.transpose(step, (0, 2, 1)))
    vec = np.stack([skew_part[:, 2, 1], skew_part[:, 0, 2], skew_part[:, 1, 0]], axis=1)
    sin = np.linalg.norm(vec, axis=1)
    cos = 0.5 * (np.trace(step, axis1=1, axis2=2) - 1.0)
    angle = np.arctan2(sin, cos)
    scale = np.divide(angle, sin, out=np.ones_like(sin), where=sin > 1e-15)
    turns: FloatArray = (vec * scale[:, None]) @ np.asarray(axis_ned, dtype=np.float64)
    return turns


def attitude_rate_deg_s(
    t_s: FloatArray, R_body_to_ned: FloatArray, axis_ned: tuple[float, float, float]
) -> float | None:
    """Mean rate of the attitude about the table axis over some records (deg/s).

    Parameters
    ----------
    t_s : ndarray, shape (M,)
        Record times (s), increasing.
    R_body_to_ned : ndarray, shape (M, 3, 3)
        Attitude at those times.
    axis_ned : tuple of 3 float
        The table's rotation axis (unit vector).

    Returns
    -------
    float or None
        The turns between consecutive records (``R_k+1 R_k^T``, navigation frame)
        projected on the axis, summed and divided by the time spanned (deg/s),
        right-handed about ``axis_ned``; None for fewer than 2 records.
    """
    if len(t_s) < 2 or float(t_s[-1] - t_s[0]) <= 0.0:
        return None
    turned = float(np.sum(_axis_turns_rad(R_body_to_ned, axis_ned)))
    return math.degrees(turned / float(t_s[-1] - t_s[0]))


def attitude_rate_std_deg_s(
    t_s: FloatArray, R_body_to_ned: FloatArray, axis_ned: tuple[float, float, float]
) -> float:
    """A generous sigma of `attitude_rate_deg_s` from the scatter of the record turns (deg/s).

    The turns less the mean rate times each interval, taken as independent (a random
    walk: larger than the sigma of white attitude noise, whose turns cancel in the sum);
    inf for fewer than 3 records.
    """
    span = float(t_s[-1] - t_s[0]) if len(t_s) >= 3 else 0.0
    if span <= 0.0:
        return math.inf
    turns = _axis_turns_rad(R_body_to_ned, axis_ned)
    rest = turns - float(np.sum(turns)) / span * np.diff(t_s)
    return math.degrees(float(np.std(rest)) * math.sqrt(rest.size) / span)


def attitude_rate_offsets(rates: Sequence[tuple[str, float, float, float]], shown_by: str) -> str:
    """The passes whose stated rate the attitude log contradicts, in words; "" if none.

    Parameters
    ----------
    rates : sequence of (str, float, float, float)
        Each judged pass: its name, stated rate, the log's rate and that rate's sigma
        (`attitude_rate_std_deg_s`), deg/s. A pass is off when the two differ by more
        than `ATTITUDE_RATE_TOLERANCE` of the stated rate and 5 sigma.
    shown_by : str
        What shows the rate, e.g. "the attitude log attitude.csv".
    """
    off = [
        (name, stated, shown)
        for name, stated, shown, std in rates
        if abs(shown - stated) > max(ATTITUDE_RATE_TOLERANCE * abs(stated), _OFFSET_SIGMAS * std)
    ]
    if not off:
        return ""
    listed = "; ".join(
        f"{name}: stated {stated:+.4g} deg/s, shows {shown:+.4g} deg/s "
        f"({100.0 * (stated / shown - 1.0):+.1f} %)"
        for name, stated, shown in off[:_SHOWN_MAX]
    )
    if len(off) > _SHOWN_MAX:
        listed += f"; and {len(off) - _SHOWN_MAX} more"
    ratios = np.array([stated / shown for _, stated, shown in off])
    gon = (
        " (about 400/360 in every pass: rates in gon/s?)"
        if len(off) == len(rates) and np.all(np.abs(ratios / _GON_PER_DEG - 1.0) < 0.005)
        else ""
    )
    what = f"{len(off)} of {counted(len(rates), 'pass', 'passes')}"
    return (
        f"the stated table rate of {what} is more than "
        f"{100.0 * ATTITUDE_RATE_TOLERANCE:g} % off the rate {shown_by} shows ({listed})"
        f"{gon}: a rate off by some % scales the latency by as much; give each pass's "
        "rate in deg/s as the table turned (the log's rate) in passes.csv"
    )


def mismatch_message(
    mismatches: Sequence[RateMismatch], n_checked: int, shown_by: str, *, points: bool
) -> str:
    """The mismatches in a few plain lines' worth of text, with what to do.

    Parameters
    ----------
    mismatches : sequence of RateMismatch
        At least one.
    n_checked : int
        Passes whose rate could be judged.
    shown_by : str
        What shows the rate, e.g. "the points' azimuth about the axis" or "the attitude
        log attitude.csv".
    points : bool
        True when the points show the rate: the message then also names a frame
        mix-up (ENU for NED) and a length unit as causes.
    """
    ratios = np.array([m.ratio for m in mismatches])
    listed = "; ".join(m.text() for m in mismatches[:_SHOWN_MAX])
    if len(mismatches) > _SHOWN_MAX:
        listed += f"; and {len(mismatches) - _SHOWN_MAX} more"
    every = len(mismatches) == n_checked
    lo, hi = _DEG_PER_RAD / _UNIT_TOLERANCE, _DEG_PER_RAD * _UNIT_TOLERANCE
    if every and np.all((ratios > 1.0 / hi) & (ratios < 1.0 / lo)):
        return (
            f"the table rate shown by {shown_by} is about 57 times smaller than the stated "
            f"rate in every pass ({listed}): angles in radians read as degrees? kinsync "
            "reads attitude angles in degrees"
        )
    if every and np.all((ratios > lo) & (ratios < hi)):
        return (
            f"the stated table rates look like rad/s: {shown_by} shows about 57 times more "
            f"in every pass ({listed}); give rate_deg_s in deg/s"
        )
    enu = (
        ", or, if the points are in ENU rather than the table-centred NED frame (x and y "
        "swapped, z up), convert them"
        if points
        else ""
    )
    if every and np.all(ratios < 0):
        return (
            f"every pass turns the other way than its stated table rate ({listed}; shown "
            f"by {shown_by}): the rates' sign convention is the opposite of kinsync's "
            "(positive is right-handed about the axis: about +Down, clockwise seen from "
            f"above): negate rate_deg_s in passes.csv{enu}"
        )
    one = len(mismatches) == 1
    what = f"{len(mismatches)} of {counted(n_checked, 'pass')} " + ("turns" if one else "turn")
    its = "its" if one else "their"
    if np.all(ratios < 0):
        return (
            f"{what} the other way than {its} stated table rate ({listed}; shown by "
            f"{shown_by}): correct {its} sign in passes.csv (positive is right-handed "
            "about the axis: about +Down, clockwise seen from above)"
        )
    return (
        f"{what} otherwise than {its} stated table rate ({listed}; shown by "
        f"{shown_by}): check each pass's signed rate and its unit (deg/s) in passes.csv"
        + (", and that the points are in metres in the table-centred NED frame" if points else "")
    )


def judge_rates(
    passes: Sequence[SpherePass], shown_rate_deg_s: Callable[[SpherePass], float | None]
) -> tuple[list[RateMismatch], int]:
    """Each pass's stated rate against the rate ``shown_rate_deg_s`` gives (deg/s).

    Returns
    -------
    mismatches : list of RateMismatch
        The passes whose shown rate `rate_mismatch` refuses.
    n_checked : int
        Passes judged (``shown_rate_deg_s`` gave a rate, not None).
    """
    mismatches: list[RateMismatch] = []
    n_checked = 0
    for p in passes:
        shown = shown_rate_deg_s(p)
        if shown is None:
            continue
        n_checked += 1
        if rate_mismatch(p.rate_deg_s, shown):
            mismatches.append(RateMismatch(p.source, p.rate_deg_s, shown))
    return mismatches, n_checked


def check_pass_rates(passes: Sequence[SpherePass]) -> int:
    """Raise when a pass's points turn otherwise than its stated table rate.

    Parameters
    ----------
    passes : sequence of SpherePass
        As for `rate_check_counts`.

    Returns
    -------
    int
        The passes checked; `rate_check_counts` also counts those with times whose
        points do not turn about their axis.
    """
    return rate_check_counts(passes)[0]


def rate_check_counts(passes: Sequence[SpherePass]) -> tuple[int, int]:
    """Raise when a pass's points turn otherwise than its stated table rate.

    Each pass with point times is judged by `points_azimuth_rate_deg_s`; a pass
    without times, or whose points do not sweep with time, is not judged by them, and
    counts as checked only when its ``rate_checked_by`` says what else confirmed it
    (the attitude log of a raw pass).

    Parameters
    ----------
    passes : sequence of SpherePass
        The passes, each with its stated table rate (deg/s, signed, right-handed about
        its axis), rotation axis and points (table-centred NED, m) with their times
        (s) where the file has them.

    Returns
    -------
    n_checked : int
        Passes checked (judged by their points, each agreeing with its stated rate, or
        ``rate_checked_by``); 0 when none could be (no point times): then a wrong
        sign, rad/s for deg/s or ENU for NED goes unseen (`unchecked_rates_text`).
    n_unswept : int
        Passes not checked although their points have times: the points do not turn
        about the stated axis (a wrong axis, points not table-centred, or a scanner
        that does not sweep with the table).

    Raises
    ------
    InputError
        A pass whose points turn the other way, or more than a factor
        `RATE_RATIO_LIMIT` faster or slower, than its stated rate: naming the pass,
        its stated rate and the rate its points show (`mismatch_message`).
    """
    checked: list[bool] = []  # per pass: judged by its points, or confirmed before
    unswept: list[bool] = []  # per pass: times, yet not judged, nor confirmed before

    def shown_by_points(p: SpherePass) -> float | None:
        rate = (
            None if p.t_s is None else points_azimuth_rate_deg_s(p.points_ned_m, p.t_s, p.axis_ned)
        )
        checked.append(rate is not None or p.rate_checked_by is not None)
        unswept.append(not checked[-1] and p.t_s is not None)
        return rate

    mismatches, n_judged = judge_rates(passes, shown_by_points)
    if mismatches:
        raise InputError(
            mismatch_message(
                mismatches, n_judged, "the points' azimuth about the axis", points=True
            )
        )
    return sum(checked), sum(unswept)


def unchecked_rates_text(n_checked: int, n_passes: int, n_unswept: int = 0) -> str:
    """What was not checked of the passes' stated rates, in words; "" when every pass was.

    Parameters
    ----------
    n_checked : int
        Passes whose points judged their stated rate (`check_pass_rates`).
    n_passes : int
        Passes given.
    n_unswept : int
        Of the passes not checked, those whose points have times but do not turn about
        the stated axis (`rate_check_counts`): the text then points at the axis and the
        frame rather than asking for times.
    """
    if n_checked >= n_passes:
        return ""
    n_unchecked = n_passes - n_checked
    head = (
        f"the sign and unit of the table rates were not checked on {n_unchecked} "
        f"of {counted(n_passes, 'pass', 'passes')}"
    )
    risk = "a wrong sign flips the latency and rad/s given as deg/s scales it 57 times, unseen"
    if n_unswept == 0:
        which = "none" if n_checked == 0 else f"only {n_checked}"
        return (
            f"{head} ({which} of them with point times that sweep with the table): {risk}; "
            "give the points' times (a t_s column) or check passes.csv by hand"
        )
    if n_unswept == n_unchecked:
        which, untimed = "their points have times (t_s) but", ""
    else:
        which = f"{n_unswept} of them have point times (t_s) but their points"
        untimed = f"; the other {n_unchecked - n_unswept} have no point times (a t_s column)"
    return (
        f"{head}: {which} do not turn about the stated axis as a profile scanner on the "
        "table axis would: check the axis in passes.csv (axis_n,axis_e,axis_d, NED; "
        "default 0,0,1 = Down) and that the points are table-centred (origin on the table "
        f"axis){untimed}; {risk}, so check passes.csv by hand too"
    )


class RatesUncheckedWarning(KinsyncWarning):
    """The sign and unit of some passes' stated table rates could not be checked.

    A wrong sign then flips the latency, rad/s given as deg/s scales it 57 times, and
    nothing else shows it (`unchecked_rates_text`).
    """


def warn_unchecked_rates(n_checked: int, n_passes: int, n_unswept: int = 0) -> None:
    """Issue a `RatesUncheckedWarning` when some passes' rates went unchecked.

    Parameters
    ----------
    n_checked, n_passes, n_unswept : int
        As `unchecked_rates_text`, whose text the warning carries; none when it is "".
    """
    text = unchecked_rates_text(n_checked, n_passes, n_unswept)
    if text:
        # stacklevel 3: the line that called estimate_latency_sphere
        warnings.warn(text, RatesUncheckedWarning, stacklevel=3)
