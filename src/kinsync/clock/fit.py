"""PPS + ZDA time tagging: the local acquisition clock mapped to GPS time (SPEC section 6).

An acquisition computer time-tags, with its own drifting clock, every edge of a GNSS
receiver's pulse per second (PPS) and the arrival of each ZDA message that names the
UTC second of an edge. This module turns those two logs into a
`kinsync.clock.model.ClockModel` (offset and drift, optionally piecewise).

Pairing a ZDA with its pulse
    The ZDA's arrival time is the end of its reception. Its transmission started
    ``(len(sentence) + 2) * bits_per_byte / baud`` earlier (the ``+ 2`` is the CR LF;
    `kinsync.budget.serial_transmission_time_s`). By default (``"preceding"``) a ZDA
    names the UTC time of the last PPS edge before its transmission started; with
    ``"following"`` (the other vendor convention, a message announcing the next
    second) it names the first edge after.

Robust fit (`fit_clock`)
    1. The pulses alone fix a 1 s grid: the local period is the median of the
       intervals that are whole seconds within 1 %, the grid phase the middle of what
       the densest 0.2 s window of the pulse phases holds, refined by a median (so the
       larger part of a log with a step sets it); every pulse gets the nearest count.
    2. Pulses off the grid are rejected iteratively (`kinsync.clock.grid`): a robust
       (Theil-Sen) line through the pulses within 0.1 s of the grid makes the first
       cut, then least squares of count on local time over the kept pulses, residuals
       of all pulses, robust scale 1.4826 * MAD of the n pulses within 0.1 s, keep
       ``|residual| <= max((6 + 300 / n**2) * scale, 10 us)`` (one pulse per count, the
       closest), until the kept set no longer changes. The threshold shrinks at most
       tenfold per pass, so an outlier that tilts a fit cannot drag the good pulses
       out with it. Rejected pulses are *spurious*.
    3. Each ZDA names a count on that grid (the last count before its transmission
       start, or the next one); the difference between the ZDA's GPS second and that
       count is the grid's absolute label. The label most ZDAs agree on (a strict
       majority is required) is adopted; a ZDA that disagrees names the *wrong
       second* and is rejected. A ZDA whose named second has no good pulse (missing,
       or outside the log) is *unpaired* and rejected too.
    4. Final least squares of the GPS seconds of the good pulses on their local times;
       the covariance of offset and drift uses the residual variance ``RSS / (n - 2)``.
       GPS seconds inside the span of good pulses that have no good pulse are
       *missing*. A ZDA naming the same second as an earlier one (a line logged twice)
       is *repeated* and rejected, so one ZDA pairs with each pulse.
    5. A step of the local clock (its time jumps and stays jumped) would make one
       offset-and-drift line wrong for the whole log, so it is refused, naming the
       pulses it lies between. Three signs, each persistent (isolated spurious pulses
       and wrong ZDAs show none): at least 3 off-grid pulses at distinct seconds that
       share a phase of their own where the grid has no good pulse
       (`_check_phase_gaps`); at least 5 consecutive ZDAs naming one second, then at
       least 5 naming another (`_find_zda_step`: a jump by whole seconds, which the
       pulses alone cannot show); a jump of the good pulses' phase that stays (a
       step below the rejection threshold, `_find_phase_jump`). They are checked in
       the order phase gaps, phase jumps, ZDAs.
    6. Plausibility (`kinsync.clock.plausibility`): a `KinsyncWarning` names a --baud
       the sentence spacing contradicts, ZDAs starting over 0.5 s after their edge,
       pulses scattered over 1 ms rms, residuals that follow each other (the sigmas
       count pulse jitter only), and ZDAs straddling their edge (each then names the
       edge it starts at).

Optionally (``piecewise=True``) the model also interpolates linearly between
consecutive good pulses. A ZDA's UTC date and time become GPS time through the
leap-second table (`kinsync.clock.leap_seconds`).
"""

from __future__ import annotations

import math
import warnings
from collections import Counter
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._text import shown_value
from kinsync._typing import ArrayLike, BoolArray, FloatArray, IntArray
from kinsync._unix_time import check_not_future
from kinsync._validate import positive_number
from kinsync.budget import Parity, serial_transmission_time_s
from kinsync.clock.grid import grid_labels, line_fit, unit_hint
from kinsync.clock.leap_seconds import zda_to_gps_s
from kinsync.clock.model import ClockModel, _finite_times
from kinsync.clock.plausibility import (
    pulse_scatter_note,
    residual_structure_note,
    sentence_spacing_note,
    zda_delay_note,
)
from kinsync.clock.steps import (
    WHOLE_SECOND_TOLERANCE_S,
    check_phase_gaps,
    check_steps,
    find_phase_jump,
    find_zda_step,
    wrap,
)
from kinsync.errors import InputError, KinsyncWarning, ObservabilityError
from kinsync.messages import NmeaLog, RejectedLine, ZdaRecord
from kinsync.trajectory_times import backward_step_s

__all__ = [
    "CONVENTIONS",
    "MAX_LOG_SPAN_S",
    "ClockFit",
    "Convention",
    "fit_clock",
    "fit_clock_to_log",
    "message_transmission_time_s",
]

Convention = Literal["preceding", "following"]
"""Which PPS edge a ZDA names: the last before its transmission, or the next one."""
CONVENTIONS: tuple[Convention, ...] = ("preceding", "following")

MAX_LOG_SPAN_S = 30 * 86_400.0
"""Longest span of good pulses one clock model covers (s, 30 days). Every missing
second in between is listed (`ClockFit.missing_gps_s`), and one offset-and-drift line
over months is not a clock model: a longer span is a stray or mistyped pulse, or the
logs of several sessions run together."""


def message_transmission_time_s(
    sentence: str,
    baud: float,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> float:
    """Time to send an NMEA sentence and its CR LF over a serial line (s).

    ``(len(sentence) + 2) * bits_per_byte / baud`` through
    `kinsync.budget.serial_transmission_time_s` (the FIFO delay of ``budget serial``).

    Parameters
    ----------
    sentence : str
        The sentence as sent, ``$`` to checksum, without the line end.
    baud : float
        Line rate (bit/s).
    data_bits, parity, stop_bits
        Frame format (default 8N1: 10 bits per byte).

    Raises
    ------
    InputError
        ``sentence`` not text (a byte count: the message names
        `kinsync.budget.serial_transmission_time_s`, which takes one), or the
        frame's refusals.
    """
    if not isinstance(sentence, str):
        msg = (
            f"sentence: expected the NMEA sentence as text ('$' to checksum), got "
            f"{shown_value(sentence)}; for a length in bytes use "
            "kinsync.budget.serial_transmission_time_s(len + 2, baud) (+ 2: the CR LF)"
        )
        raise InputError(msg)
    n_bytes = len(sentence.encode("ascii", errors="replace")) + 2
    return serial_transmission_time_s(n_bytes, baud, data_bits, parity, stop_bits)


# --------------------------------------------------------------------------- model


# --------------------------------------------------------------------------- fit


@dataclass(frozen=True, eq=False)
class ClockFit(ReadOnlyArrays):
    """Result of `fit_clock`: the model, its uncertainty and every fault found.

    Attributes
    ----------
    model : ClockModel
        The fitted model (piecewise when asked).
    convention : {"preceding", "following"}
        Which edge a ZDA was taken to name.
    baud : float
        Serial line rate used for the ZDA transmission times (bit/s).
    t_local_s : ndarray, shape (K,)
        Local times of the good pulses (s).
    t_gps_s : ndarray, shape (K,)
        GPS seconds they mark (whole seconds).
    residuals_s : ndarray, shape (K,)
        ``t_gps_s - model(t_local_s)`` for the linear model (GPS seconds).
    residual_rms_s : float
        RMS of the residuals (s).
    offset_std_s, drift_std_ppm : float
        Standard deviations of ``reference_gps_s`` (equivalently ``offset_s``) and
        ``drift_ppm`` from the least-squares covariance scaled by ``RSS / (K - 2)``;
        the offset's includes, in quadrature, the rounding of ``reference_gps_s`` to a
        float64 (up to 1.2e-7 s for a GPS time from 2004 on; 69 ns rms where the pulse
        jitter exceeds a step of 2.4e-7 s).
    offset_drift_cov : ndarray, shape (2, 2)
        Covariance of (``reference_gps_s`` in s, ``drift_ppm`` in ppm), that rounding
        included.
    n_pulses_read : int
        Pulses in the input, ``n_pulses + n_spurious``.
    missing_gps_s : ndarray, shape (n_missing,)
        GPS seconds inside the span of good pulses with no good pulse.
    spurious_t_local_s : ndarray, shape (n_spurious,)
        Local times of the pulses off the 1 s grid (or duplicates of a second).
    n_zda : int
        ZDA messages given to the fit.
    wrong_zda_t_local_s : ndarray, shape (n_wrong_zda,)
        Arrival times of ZDAs whose named second disagrees with the pulse grid.
    unpaired_zda_t_local_s : ndarray, shape (n_unpaired_zda,)
        Arrival times of ZDAs whose named second has no good pulse.
    duplicate_zda_t_local_s : ndarray, shape (n_duplicate_zda,)
        Arrival times of ZDAs naming the same second as an earlier one that agrees with
        the grid (a line logged twice): one ZDA per second is paired, the others are
        rejected.
    n_bad_lines : int
        Corrupt lines of the NMEA log (bad checksum, truncated, bad field, bad time,
        ...), the ZDAs of `rejected_zdas` included. Well-formed sentences of types
        kinsync does not read (GSV, ...) are not messages lost, so they are not counted.
    zda_delay_s : float
        Median time from the named edge to the start of a paired ZDA's transmission
        (s): about the receiver's output delay for ``"preceding"``, negative (the delay
        minus 1 s) for ``"following"``. A value out of line with the receiver's manual
        hints at the wrong convention.
    rejected_zdas : tuple of RejectedLine
        ZDAs the reader accepted whose UTC has no GPS time (a 23:59:60 on a day
        without a leap second, a date before 1980-01-06), each with its line and
        reason (`fit_clock_to_log`; empty from `fit_clock`).
    """

    model: ClockModel
    convention: Convention
    baud: float
    t_local_s: FloatArray
    t_gps_s: FloatArray
    residuals_s: FloatArray
    residual_rms_s: float
    offset_std_s: float
    drift_std_ppm: float
    offset_drift_cov: FloatArray
    n_pulses_read: int
    missing_gps_s: FloatArray
    spurious_t_local_s: FloatArray
    n_zda: int
    wrong_zda_t_local_s: FloatArray
    unpaired_zda_t_local_s: FloatArray
    duplicate_zda_t_local_s: FloatArray
    n_bad_lines: int
    zda_delay_s: float
    rejected_zdas: tuple[RejectedLine, ...] = ()

    @property
    def n_pulses(self) -> int:
        """Good pulses used in the fit."""
        return len(self.t_local_s)

    @property
    def n_missing(self) -> int:
        """Whole GPS seconds inside the span with no good pulse."""
        return len(self.missing_gps_s)

    @property
    def n_spurious(self) -> int:
        """Pulses rejected as off the 1 s grid."""
        return len(self.spurious_t_local_s)

    @property
    def n_wrong_zda(self) -> int:
        """ZDAs naming a second that disagrees with the pulse grid."""
        return len(self.wrong_zda_t_local_s)

    @property
    def n_unpaired_zda(self) -> int:
        """ZDAs whose named second has no good pulse."""
        return len(self.unpaired_zda_t_local_s)

    @property
    def n_duplicate_zda(self) -> int:
        """ZDAs naming a second an earlier ZDA already named (a repeated line)."""
        return len(self.duplicate_zda_t_local_s)

    @property
    def n_zda_paired(self) -> int:
        """ZDAs paired with a good pulse (one per second)."""
        return self.n_zda - self.n_wrong_zda - self.n_unpaired_zda - self.n_duplicate_zda

    @property
    def n_rejected_messages(self) -> int:
        """Bad NMEA lines + wrong ZDAs + unpaired ZDAs + repeated ZDAs."""
        return self.n_bad_lines + self.n_wrong_zda + self.n_unpaired_zda + self.n_duplicate_zda

    def mapped_std_s(self, t_local_s: ArrayLike) -> FloatArray:
        """Standard deviation of the linear model's GPS time at local times (s).

        The fit's uncertainty and the rounding of `ClockModel.apply`'s float64 output, in
        quadrature: a GPS time near 1.4e9 s is held in steps of 2.4e-7 s, so the time
        ``apply`` returns is off the fitted line by up to half a step, uniformly (a
        standard deviation of step / sqrt(12), 6.9e-8 s), as much as the fit itself of a
        10-minute log with 1 us pulse jitter.

        Parameters
        ----------
        t_local_s : array_like, shape (...)
            Local times (s).

        Returns
        -------
        ndarray, shape (...)
            ``sqrt(J C J^T + s^2 / 12)`` with ``J = [1, (t - reference_local_s) * 1e-6]``
            and ``s`` the float64 spacing (``np.spacing``) at the GPS time.
        """
        t = _finite_times(t_local_s, "t_local_s")
        dt = t - self.model.reference_local_s
        x = dt * 1e-6
        c = self.offset_drift_cov
        var = c[0, 0] + 2.0 * x * c[0, 1] + x * x * c[1, 1]
        step = np.spacing(np.abs(self.model.reference_gps_s + dt))  # float64 step of apply()
        return np.asarray(np.sqrt(np.maximum(var, 0.0) + step * step / 12.0), dtype=np.float64)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready summary (what ``kinsync clock fit --json`` prints)."""
        m = self.model
        return {
            "offset_s": m.offset_s,
            "drift_ppm": m.drift_ppm,
            "reference_local_s": m.reference_local_s,
            "reference_gps_s": m.reference_gps_s,
            "formula": m.formula,
            "offset_std_s": self.offset_std_s,
            "drift_std_ppm": self.drift_std_ppm,
            "residual_rms_s": self.residual_rms_s,
            "span_local_s": list(m.span_local_s),
            "piecewise": m.knots_document(),
            "convention": self.convention,
            "baud": self.baud,
            "zda_delay_s": self.zda_delay_s,
            "n_pulses": self.n_pulses,
            "n_pulses_read": self.n_pulses_read,
            "n_missing": self.n_missing,
            "n_spurious": self.n_spurious,
            "n_zda": self.n_zda,
            "n_zda_paired": self.n_zda_paired,
            "n_wrong_zda": self.n_wrong_zda,
            "n_unpaired_zda": self.n_unpaired_zda,
            "n_duplicate_zda": self.n_duplicate_zda,
            "n_bad_lines": self.n_bad_lines,
            "n_rejected_messages": self.n_rejected_messages,
            "missing_gps_s": self.missing_gps_s.tolist(),
            "spurious_t_local_s": self.spurious_t_local_s.tolist(),
            "wrong_zda_t_local_s": self.wrong_zda_t_local_s.tolist(),
            "unpaired_zda_t_local_s": self.unpaired_zda_t_local_s.tolist(),
            "duplicate_zda_t_local_s": self.duplicate_zda_t_local_s.tolist(),
            "rejected_zdas": [
                {"line": r.line, "t_local_s": r.t_local_s, "reason": r.reason}
                for r in self.rejected_zdas
            ],
        }


def _one_dimensional(values: FloatArray, name: str) -> FloatArray:
    """``values`` unchanged if 1-D; one check for the pulse and ZDA arrays alike."""
    if values.ndim != 1:
        msg = f"{name}: expected a 1-D array, one value per row, got shape {values.shape}"
        raise InputError(msg)
    return values


def _increasing_times(values: ArrayLike, name: str) -> FloatArray:
    t = _one_dimensional(_finite_times(values, name), name)
    steps = np.diff(t)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        step_s = backward_step_s(t, i)
        if step_s is not None:
            before, now = float(t[i - 1]), float(t[i])
            msg = (
                f"{name}: index {i} ({now!r}) comes before index {i - 1} ({before!r}) and "
                "the times rise again from there: the local clock stepped back by about "
                f"{-step_s:.6g} s there; split the logs at {now!r} and fit each part on its own"
            )
            raise InputError(msg)
        msg = (
            f"{name}: times must be strictly increasing; index {i} ({t[i]!r}) does not "
            f"follow index {i - 1} ({t[i - 1]!r}); sort the log and remove duplicates"
        )
        raise InputError(msg)
    return t


def _check_log_span(t: FloatArray, labels: IntArray, good: BoolArray) -> None:
    """Refuse good pulses spanning more than `MAX_LOG_SPAN_S`, naming the largest gap."""
    g = np.flatnonzero(good)
    span_s = float(labels[g[-1]] - labels[g[0]])
    if span_s <= MAX_LOG_SPAN_S:
        return
    i = int(np.argmax(np.diff(t[g])))
    a, b = int(g[i]), int(g[i + 1])
    msg = (
        f"the pulses span {span_s:.0f} s ({span_s / 86_400:.1f} days), more than the "
        f"{MAX_LOG_SPAN_S / 86_400:.0f} days one clock model covers; the largest gap, "
        f"{float(t[b] - t[a]):.0f} s, lies between pulse {a} (t_local_s={float(t[a])!r}) "
        f"and pulse {b} (t_local_s={float(t[b])!r}), counted from 0: remove a stray or "
        "mistyped pulse, or fit each session's log on its own"
    )
    raise InputError(msg)


def _zda_arrays(
    zda_t_local_s: ArrayLike, zda_gps_s: ArrayLike, zda_n_bytes: ArrayLike
) -> tuple[FloatArray, FloatArray, IntArray]:
    z_t = _one_dimensional(_finite_times(zda_t_local_s, "zda_t_local_s"), "zda_t_local_s")
    z_gps = _one_dimensional(_finite_times(zda_gps_s, "zda_gps_s", "gps"), "zda_gps_s")
    check_not_future(z_gps, lambda i: f"zda_gps_s: index {i} (0-based)")
    try:
        z_bytes = np.asarray(zda_n_bytes, dtype=np.float64)
    except (TypeError, ValueError) as err:
        msg = f"zda_n_bytes: expected whole numbers ({err})"
        raise InputError(msg) from err
    if z_bytes.ndim == 0:
        msg = (
            f"zda_n_bytes: expected one byte count per ZDA message, got the single number "
            f"{zda_n_bytes!r}; repeat it, e.g. np.full(len(zda_t_local_s), {zda_n_bytes!r})"
        )
        raise InputError(msg)
    z_bytes = _one_dimensional(z_bytes, "zda_n_bytes")
    if len(z_t) == 0:
        msg = "no ZDA message: the GPS second of the pulses cannot be named without one"
        raise InputError(msg)
    if not (len(z_t) == len(z_gps) == len(z_bytes)):
        msg = (
            "zda_t_local_s, zda_gps_s and zda_n_bytes must have one length, got "
            f"{len(z_t)}, {len(z_gps)} and {len(z_bytes)}"
        )
        raise InputError(msg)
    if not np.all(np.isfinite(z_bytes)) or np.any(z_bytes != np.rint(z_bytes)):
        msg = "zda_n_bytes: every byte count must be a whole number"
        raise InputError(msg)
    if np.any(z_bytes < 1):
        i = int(np.flatnonzero(z_bytes < 1)[0])
        msg = (
            f"zda_n_bytes: index {i} holds {z_bytes[i]:g}; each is the ZDA message's length "
            "on the wire, line end included (len(sentence) + 2), so at least 1"
        )
        raise InputError(msg)
    return z_t, z_gps, z_bytes.astype(np.int64)


_SHOWN_LABELS = 5
"""GPS-second labels listed when the ZDAs have no majority."""


def _majority_label(k_zda: FloatArray, z_t: FloatArray) -> tuple[int, BoolArray]:
    """The absolute label most ZDAs give the grid (strict majority) and who disagrees.

    ``z_t`` (the ZDAs' arrival times, s) only serves the message: a spacing of about
    1000 says the NMEA times are in milliseconds.
    """
    k_int = np.rint(k_zda)
    whole = np.abs(k_zda - k_int) <= WHOLE_SECOND_TOLERANCE_S
    values, counts = np.unique(k_int[whole], return_counts=True)
    if len(values) == 0 or 2 * int(counts.max()) <= len(k_zda):
        # The most common labels first, a few only: one per ZDA made a 100 kB line.
        top = np.argsort(-counts, kind="stable")[:_SHOWN_LABELS]
        detail = ", ".join(f"{int(counts[i])} x {values[i] - values[0]:+.0f} s" for i in top)
        if len(values) > _SHOWN_LABELS:
            detail += f" and {len(values) - _SHOWN_LABELS} more"
        if int(np.count_nonzero(~whole)):
            detail += f"; {int(np.count_nonzero(~whole))} name no whole second"
        hint = ""
        if len(z_t) > 1:
            hint = unit_hint(float(np.median(np.diff(np.sort(z_t)))), "the ZDAs")
        msg = (
            f"the {len(k_zda)} ZDA messages do not agree on which GPS second the pulses mark "
            f"(no strict majority: {detail if len(values) else 'none names a whole second'})"
            f"{hint}; check --convention, --baud and that the two logs come from the same "
            "clock"
        )
        raise InputError(msg)
    k = int(values[np.argmax(counts)])
    return k, np.asarray(~(whole & (k_int == k)), dtype=np.bool_)


def _repeated_seconds(z_t: FloatArray, named: IntArray, agree: BoolArray) -> BoolArray:
    """ZDAs (of those that agree with the grid) naming a count an earlier one named.

    A sentence logged twice would pair two ZDAs with one pulse; the first in time is
    kept.
    """
    idx = np.flatnonzero(agree)
    idx = idx[np.argsort(z_t[idx], kind="stable")]
    _, first = np.unique(named[idx], return_index=True)
    out = np.zeros(len(z_t), dtype=np.bool_)
    out[idx] = True
    out[idx[first]] = False
    return out


def _final_least_squares(
    t_good: FloatArray, gps_good: FloatArray
) -> tuple[float, float, FloatArray, FloatArray]:
    """Reference GPS time, drift (ppm), residuals and covariance of the linear model.

    Solved in small numbers, ``(gps - gps0) - x = a + e x`` with ``x = t - t_good[0]``,
    so the drift comes out directly and the GPS magnitude costs no precision. The
    reference's variance includes the square of its rounding to a float64.
    """
    xg = t_good - t_good[0]
    yg = gps_good - gps_good[0]
    a, e = line_fit(xg, yg - xg)
    resid = yg - (a + xg * (1.0 + e))
    n = len(xg)
    sigma2 = float(np.sum(resid**2)) / (n - 2)
    xm = float(np.mean(xg))
    sxx = float(np.sum((xg - xm) ** 2))
    cov = np.array(
        [
            [sigma2 * (1.0 / n + xm * xm / sxx), -sigma2 * xm / sxx * 1e6],
            [-sigma2 * xm / sxx * 1e6, sigma2 / sxx * 1e12],
        ]
    )
    # reference_gps_s is a float64 near 1e9 s: it holds only values 2.4e-7 s apart (from
    # 2^30 s, 2004 on). Its rounding, known here in small numbers and at most half a
    # step, is a bias of the whole line: added to the offset's variance.
    ref_gps = float(gps_good[0]) + a
    rounding_s = (ref_gps - float(gps_good[0])) - a
    cov[0, 0] += rounding_s**2
    return ref_gps, e * 1e6, resid, cov


def _resolution_s(t_good: FloatArray, gps_good: FloatArray) -> float:
    """Float64 step of the largest local or GPS time of the good pulses (s)."""
    return max(math.ulp(float(np.max(np.abs(t_good)))), math.ulp(float(np.max(gps_good))))


_STRADDLE_WINDOW = 0.05
"""ZDAs whose transmission starts within this of an edge (in grid counts, about s)..."""
_STRADDLE_SHARE = 0.1
"""...at least this share of them on either side of it: the ZDAs straddle the edge."""


def _named_counts(start_count: FloatArray, convention: Convention) -> tuple[IntArray, str | None]:
    """Grid count each ZDA names, from its transmission start in grid counts.

    The last count before the start (``"preceding"``) or the next one. ZDAs that start
    at the edge itself (some within `_STRADDLE_WINDOW` before it, some after, each side
    at least `_STRADDLE_SHARE` of them) cannot tell the edge before from the edge after:
    the arrival jitter puts them on either side. Each then names the edge it starts at,
    under either convention (just after an edge it names, just before an edge it
    announces), and a note says so; read by the convention, half would name a wrong
    second and look like a step of the local clock.
    """
    phase = wrap(start_count)
    near = np.abs(phase) < _STRADDLE_WINDOW
    before = int(np.count_nonzero(near & (phase < 0.0)))
    after = int(np.count_nonzero(near & (phase >= 0.0)))
    if min(before, after) >= _STRADDLE_SHARE * len(phase):
        median_us = float(np.median(phase[near])) * 1e6
        note = (
            f"the ZDAs start at the pulse edge itself ({before} just before it, {after} just "
            f"after, median {median_us:+.0f} us): which edge a ZDA names cannot be told from "
            f"--convention {convention}, so each was taken to name the edge it starts at; "
            "check --baud and that the NMEA times mark the end of each sentence's reception"
        )
        return np.rint(start_count).astype(np.int64), note
    shift = 1 if convention == "following" else 0
    return np.floor(start_count).astype(np.int64) + shift, None


def fit_clock(
    pps_t_local_s: ArrayLike,
    zda_t_local_s: ArrayLike,
    zda_gps_s: ArrayLike,
    zda_n_bytes: ArrayLike,
    *,
    baud: float = 115200.0,
    convention: Convention = "preceding",
    piecewise: bool = False,
    n_bad_lines: int = 0,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> ClockFit:
    """Fit the local clock -> GPS time model from PPS edges and ZDA messages, robustly.

    Parameters
    ----------
    pps_t_local_s : array_like, shape (N,)
        Local times of the detected PPS edges (s), strictly increasing, N >= 3.
    zda_t_local_s : array_like, shape (M,)
        Local arrival times (end of reception) of the ZDA messages (s), M >= 1.
    zda_gps_s : array_like, shape (M,)
        GPS time each ZDA names (s since the GPS epoch; `zda_to_gps_s`).
    zda_n_bytes : array_like, shape (M,)
        Bytes of each ZDA on the wire, line end included (``len(sentence) + 2``).
    baud : float
        Serial line rate (bit/s).
    convention : {"preceding", "following"}
        A ZDA names the last edge before its transmission started, or the next one.
    piecewise : bool
        Also interpolate linearly between consecutive good pulses.
    n_bad_lines : int
        NMEA lines already rejected by the reader (counted in ``n_rejected_messages``).
    data_bits, parity, stop_bits
        Serial frame format (default 8N1).

    Returns
    -------
    ClockFit

    Raises
    ------
    InputError
        Too few pulses, no ZDA, mismatched shapes, non-finite or unordered times, a
        ZDA GPS time after today (Unix time given as GPS time: the message says how to
        convert it),
        pulses not one second apart, ZDAs that do not agree on the second (no strict
        majority), an unknown convention, a step of the local clock (naming the pulses
        it lies between; split the logs there and fit each part).
    ObservabilityError
        Fewer than 3 pulses on a common 1 s grid, or no ZDA names the second of a good
        pulse (the GPS second of the pulses would rest on nothing).
    """
    if convention not in CONVENTIONS:
        msg = f"convention must be 'preceding' or 'following', got {convention!r}"
        raise InputError(msg)
    rate = positive_number(baud, "baud")
    if isinstance(n_bad_lines, bool) or int(n_bad_lines) != n_bad_lines or n_bad_lines < 0:
        msg = f"n_bad_lines must be a non-negative whole number, got {n_bad_lines!r}"
        raise InputError(msg)
    t = _increasing_times(pps_t_local_s, "pps_t_local_s")
    if len(t) < 3:
        msg = f"the pulse log holds {len(t)} pulse(s); at least 3 are needed to fit a clock"
        raise InputError(msg)
    z_t, z_gps, z_bytes = _zda_arrays(zda_t_local_s, zda_gps_s, zda_n_bytes)
    tx_s = np.array(
        [serial_transmission_time_s(int(n), rate, data_bits, parity, stop_bits) for n in z_bytes]
    )

    labels, good, alpha, beta = grid_labels(t)
    _check_log_span(t, labels, good)
    check_phase_gaps(t, good, alpha, beta)
    # Grid count each ZDA names: last count before the transmission start, or the next.
    start_count = alpha + beta * (z_t - tx_s - t[0])
    named, straddle = _named_counts(start_count, convention)
    check_steps(
        t,
        find_phase_jump(t, labels, good, alpha, beta),
        find_zda_step(t, labels, good, z_t, z_gps - named, named),
    )
    k, wrong = _majority_label(z_gps - named, z_t)

    gps_all = (labels + k).astype(np.float64)
    t_good = t[good]
    gps_good = gps_all[good]
    duplicate = _repeated_seconds(z_t, named, ~wrong)
    unpaired = ~wrong & ~duplicate & ~np.isin(named, labels[good])

    ref_gps, drift_ppm, resid, cov = _final_least_squares(t_good, gps_good)
    ref_local = float(t_good[0])
    span = (float(t_good[0]), float(t_good[-1]))
    model = ClockModel(
        reference_local_s=ref_local,
        reference_gps_s=ref_gps,
        drift_ppm=drift_ppm,
        span_local_s=span,
        knots_local_s=t_good if piecewise else None,
        knots_gps_s=gps_good if piecewise else None,
    )
    full = np.arange(int(labels[good][0]), int(labels[good][-1]) + 1)
    missing = np.setdiff1d(full, labels[good]) + k
    paired = ~wrong & ~unpaired & ~duplicate
    if not np.any(paired):
        msg = (
            f"none of the {len(z_t)} ZDA message(s) names the second of a detected pulse "
            f"(ZDAs at local {float(z_t[0])!r}..{float(z_t[-1])!r} s, good pulses at "
            f"{span[0]!r}..{span[1]!r} s): the GPS second of the pulses is not determined; "
            "check that the two logs overlap in time and the --convention"
        )
        raise ObservabilityError(msg)
    start_gps = model.linear().apply(z_t[paired] - tx_s[paired])
    zda_delay = float(np.median(start_gps - z_gps[paired]))
    rms_s = float(np.sqrt(np.mean(resid**2)))
    for note in (
        straddle,
        zda_delay_note(zda_delay, convention, rate),
        pulse_scatter_note(rms_s, len(t_good)),
        None if piecewise else residual_structure_note(resid, _resolution_s(t_good, gps_good)),
    ):
        if note is not None:
            warnings.warn(note, KinsyncWarning, stacklevel=2)
    return ClockFit(
        model=model,
        convention=convention,
        baud=rate,
        t_local_s=readonly_array(t_good),
        t_gps_s=readonly_array(gps_good),
        residuals_s=readonly_array(resid),
        residual_rms_s=rms_s,
        offset_std_s=math.sqrt(cov[0, 0]),
        drift_std_ppm=math.sqrt(cov[1, 1]),
        offset_drift_cov=readonly_array(cov),
        n_pulses_read=len(t),
        missing_gps_s=readonly_array(missing.astype(np.float64)),
        spurious_t_local_s=readonly_array(t[~good]),
        n_zda=len(z_t),
        wrong_zda_t_local_s=readonly_array(z_t[wrong]),
        unpaired_zda_t_local_s=readonly_array(z_t[unpaired]),
        duplicate_zda_t_local_s=readonly_array(z_t[duplicate]),
        n_bad_lines=int(n_bad_lines),
        zda_delay_s=zda_delay,
    )


def _commonest_reason(log: NmeaLog) -> str:
    """``; most often (N lines, first line L): reason`` of the rejected lines (ZDA first)."""
    zdas = [r for r in log.rejected if "ZDA" in r.sentence[:8]]
    lines = zdas or list(log.rejected)
    if not lines:
        return ""
    reason, count = Counter(r.reason for r in lines).most_common(1)[0]
    first = next(r.line for r in lines if r.reason == reason)
    what = "ZDA lines" if zdas else "lines"
    return f"; most often ({count} {what}, first line {first}): {reason}"


def fit_clock_to_log(
    pps_t_local_s: ArrayLike,
    log: NmeaLog,
    *,
    baud: float = 115200.0,
    convention: Convention = "preceding",
    piecewise: bool = False,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> ClockFit:
    """`fit_clock` on an NMEA log: its ZDAs, their sentence lengths and its rejected lines.

    Parameters
    ----------
    pps_t_local_s : array_like, shape (N,)
        Local times of the PPS edges (s), strictly increasing.
    log : NmeaLog
        The parsed NMEA log (`kinsync.io.nmea.read_nmea_log`); every rejected line
        counts in ``n_rejected_messages``.
    baud, convention, piecewise, data_bits, parity, stop_bits
        As in `fit_clock`.

    A ZDA whose UTC has no GPS time (23:59:60 on a day without a leap second, a date
    before 1980-01-06) is rejected like a corrupt line: listed in
    ``ClockFit.rejected_zdas`` with its line and reason, counted in ``n_bad_lines``.

    Raises
    ------
    InputError
        No ZDA in the log (naming the file), no ZDA with a GPS time (naming the line
        and reason of the first), or any error of `fit_clock`.
    """
    zda_t, zda_records, zda_sentences, zda_lines = _log_zdas(log)
    if len(zda_records) == 0:
        msg = (
            f"{log.source}: no valid ZDA sentence in the NMEA log ({len(log.records)} valid "
            f"sentence(s), {len(log.rejected)} rejected line(s){_commonest_reason(log)}); the "
            "receiver must output ZDA to name the pulses' GPS second"
        )
        raise InputError(msg)
    gps = np.full(len(zda_records), np.nan)
    rejected: list[RejectedLine] = []
    for i, record in enumerate(zda_records):
        try:
            gps[i] = zda_to_gps_s(record)
        except InputError as err:
            reason = f"{_NO_GPS_TIME}{err}"
            rejected.append(
                RejectedLine(
                    zda_lines[i] if zda_lines else 0, float(zda_t[i]), zda_sentences[i], reason
                )
            )
    if rejected and len(rejected) == len(zda_records):
        first = rejected[0]
        where = f"line {first.line}" if zda_lines else "ZDA number 1"
        more = f", and {len(rejected) - 1} more ZDA(s)" if len(rejected) > 1 else ""
        msg = (
            f"{log.source}: {where}: {first.reason.removeprefix(_NO_GPS_TIME)}{more}; no ZDA "
            "of the log names a UTC time that has a GPS time"
        )
        raise InputError(msg)
    ok = np.isfinite(gps)
    n_bytes = np.array([len(s.encode("ascii", errors="replace")) + 2 for s in zda_sentences])
    n_corrupt = sum(1 for r in log.rejected if r.unsupported_type is None)
    _warn_sentence_spacing(log, baud, data_bits, parity, stop_bits)
    fit = fit_clock(
        pps_t_local_s,
        zda_t[ok],
        gps[ok],
        n_bytes[ok],
        baud=baud,
        convention=convention,
        piecewise=piecewise,
        n_bad_lines=n_corrupt + len(rejected),
        data_bits=data_bits,
        parity=parity,
        stop_bits=stop_bits,
    )
    return replace(fit, rejected_zdas=tuple(rejected))


_NO_GPS_TIME = "ZDA time has no GPS time: "


def _log_zdas(log: NmeaLog) -> tuple[FloatArray, list[ZdaRecord], list[str], list[int]]:
    """ZDA arrival times, records, raw sentences and file lines of a log, in log order."""
    idx = [i for i, r in enumerate(log.records) if isinstance(r, ZdaRecord)]
    records = [r for r in log.records if isinstance(r, ZdaRecord)]
    t = np.asarray(log.t_local_s, dtype=np.float64)[idx]
    sentences = [log.raw_sentences[i] for i in idx]
    lines = [log.lines[i] for i in idx] if log.lines else []
    return t, records, sentences, lines


def _warn_sentence_spacing(
    log: NmeaLog, baud: float, data_bits: int, parity: Parity | str, stop_bits: float
) -> None:
    """Warn when the log's lines arrive closer together than ``baud`` lets them.

    Every line with an arrival time counts, the rejected ones too (their text as
    received), in file order when the file lines are known.
    """
    rows = [
        (line, float(t), sentence)
        for line, t, sentence in zip(
            log.lines or range(len(log.records)), log.t_local_s, log.raw_sentences, strict=True
        )
    ]
    if log.lines:
        rows += [(r.line, r.t_local_s, r.sentence) for r in log.rejected if r.t_local_s is not None]
        rows.sort(key=lambda row: row[0])
    per_byte_s = serial_transmission_time_s(
        1, positive_number(baud, "baud"), data_bits, parity, stop_bits
    )
    note = sentence_spacing_note(
        np.array([row[1] for row in rows], dtype=np.float64),
        np.array(
            [len(row[2].encode("ascii", errors="replace")) + 2 for row in rows], dtype=np.float64
        ),
        [row[0] for row in rows] if log.lines else [],
        per_byte_s,
        float(baud),
        log.source,
    )
    if note is not None:
        warnings.warn(note, KinsyncWarning, stacklevel=3)
