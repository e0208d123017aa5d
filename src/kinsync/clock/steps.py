"""Steps of the local clock in a PPS + ZDA log: found and refused, never fitted through.

A logger's clock that is stepped (by NTP, by hand) during a log breaks the one-line
model of `kinsync.clock.fit`: fitted through, it gives a reference time whole seconds
off and a tilted drift with a small σ, and blames the correct ZDAs. Three signs of a
step are looked for, each naming the pulses on either side:

- off-grid pulses at different seconds that share a phase of their own where the grid
  has no good pulse (`check_phase_gaps`);
- a lasting jump of the good pulses' phase, larger than `_STEP_SIGMAS` times their
  scatter and `_MIN_STEP_S` (`find_phase_jump`);
- a run of ZDAs naming one second, then a run naming another (`find_zda_step`).

`check_steps` raises the `InputError` that names the step and says to split the log.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.errors import InputError
from kinsync.robust import robust_sigma

__all__ = [
    "WHOLE_SECOND_TOLERANCE_S",
    "check_phase_gaps",
    "check_steps",
    "find_phase_jump",
    "find_zda_step",
    "wrap",
]

WHOLE_SECOND_TOLERANCE_S = 1e-3
"""A ZDA must name a whole second to this tolerance."""
_STEP_MIN_RUN = 3
"""Off-grid pulses that must share a phase of their own for a step of the local clock
(fewer are reported as spurious)."""
_STEP_MIN_ZDAS = 5
"""Consecutive ZDAs that must agree on a second, before and after, for a whole-second
step of the local clock (shorter runs are reported as wrong ZDAs: with 5 % of the ZDAs
wrong at random, five in a row with the same error turn up once in 10^6 logs)."""
_STEP_PHASE_TOLERANCE_S = 1e-3
"""Off-grid pulses within this of one phase (grid counts, about s) share a phase."""
_STEP_WINDOW = 20
"""Good pulses each side of a candidate jump of the good pulses' phase."""
_STEP_SIGMAS = 8.0
"""A jump of the good pulses' phase must exceed this many times their scatter ..."""
_MIN_STEP_S = 5e-6
"""... and this (s): smaller steps stay below the timing noise of a PPS capture."""


def wrap(x: FloatArray) -> FloatArray:
    """``x`` minus its nearest whole number: the phase in (-0.5, 0.5]."""
    return np.asarray(x - np.rint(x), dtype=np.float64)


def _pulse_at(t: FloatArray, i: int) -> str:
    return f"pulse {i} (t_local_s={float(t[i])!r})"


def _step_error(t: FloatArray, before: int, after: int, what: str) -> InputError:
    msg = (
        f"the local clock stepped between {_pulse_at(t, before)} and {_pulse_at(t, after)}, "
        f"pulses counted from 0: {what}; one offset and drift cannot map both sides, so "
        f"split the PPS and NMEA logs at t_local_s={float(t[after])!r} and fit each part "
        "on its own"
    )
    return InputError(msg)


def _grid_phase(t: FloatArray, alpha: float, beta: float) -> tuple[FloatArray, FloatArray]:
    """Grid position ``u`` of every pulse and its phase ``u - rint(u)`` (grid counts)."""
    u = alpha + beta * (t - t[0])
    return u, np.asarray(u - np.rint(u), dtype=np.float64)


def check_phase_gaps(t: FloatArray, good: BoolArray, alpha: float, beta: float) -> None:
    """Refuse a step of the local clock larger than the rejection threshold.

    Where the grid has no good pulse (before the first, after the last, or in a gap),
    at least `_STEP_MIN_RUN` off-grid pulses at distinct seconds that share one phase
    of their own (within `_STEP_PHASE_TOLERANCE_S`) are the clock running on after a
    jump, not spurious pulses (which fall at random phases).

    Raises
    ------
    InputError
        Naming the two pulses the step lies between and its size modulo whole seconds.
    """
    u, phase = _grid_phase(t, alpha, beta)
    g = np.flatnonzero(good)
    off = np.flatnonzero(~good)
    gap_of = np.searchsorted(g, off)  # 0: before the first good pulse, len(g): after the last
    for gap in np.unique(gap_of):
        members = off[gap_of == gap]
        if len(members) < _STEP_MIN_RUN:
            continue
        ph = np.sort(phase[members])
        ext = np.concatenate([ph, ph + 1.0])
        ends = np.searchsorted(ext, ph + 2.0 * _STEP_PHASE_TOLERANCE_S, side="right")
        i = int(np.argmax(ends - np.arange(len(ph))))
        lo_ph, hi_ph = float(ext[i]), float(ext[int(ends[i]) - 1])
        w = wrap(phase[members] - lo_ph)
        shared = members[(w >= -1e-12) & (w <= hi_ph - lo_ph + 1e-12)]
        if len(np.unique(np.rint(u[shared]))) < _STEP_MIN_RUN:
            continue
        jump = float(wrap(np.asarray([np.median(wrap(phase[shared] - lo_ph)) + lo_ph]))[0])
        if gap == 0:  # the other phase comes first: the step is where it ends
            before, after, jump = int(shared[-1]), int(g[0]), -jump
        else:
            before, after = int(g[gap - 1]), int(shared[0])
        period = 1.0 / beta
        raise _step_error(
            t,
            before,
            after,
            f"{len(shared)} pulses, where the 1 s grid of the other {len(g)} has none, "
            f"share a phase {jump * period:+.6f} s (modulo whole seconds) off it",
        )


def find_phase_jump(
    t: FloatArray, labels: IntArray, good: BoolArray, alpha: float, beta: float
) -> tuple[int, int, str] | None:
    """Find a step of the local clock smaller than the rejection threshold.

    Such a step leaves both sides among the good pulses, on a tilted line. Between two
    good pulses whose phase difference is out of line with the others, the medians of
    the phase over up to `_STEP_WINDOW` good pulses each side are compared: a jump
    larger than `_STEP_SIGMAS` times their scatter and than `_MIN_STEP_S` persists, so
    it is a step (one late pulse moves neither median).

    Returns
    -------
    tuple or None
        The pulses the first such step lies between and what shows it, or None.
    """
    _, phase = _grid_phase(t, alpha, beta)
    g = np.flatnonzero(good)
    if len(g) < 2 * _STEP_MIN_RUN:
        return None
    gl = labels[g].astype(np.float64)
    # Unwrapped: on a line tilted by a step, the phase may cross half a second.
    gp = np.unwrap(phase[g], period=1.0)
    dl = np.diff(gl)
    dp = np.diff(gp)
    dev = dp - float(np.median(dp / dl)) * dl
    sigma = robust_sigma(dev - np.median(dev)) / math.sqrt(2.0)
    cand = np.flatnonzero(np.abs(dev) > max(_STEP_SIGMAS * sigma, _MIN_STEP_S)) + 1
    for c in cand:
        left = gp[max(0, c - _STEP_WINDOW) : c]
        right = gp[c : c + _STEP_WINDOW]
        if len(left) < _STEP_MIN_RUN or len(right) < _STEP_MIN_RUN:
            continue
        m_left, m_right = float(np.median(left)), float(np.median(right))
        scatter = float(np.sqrt(np.mean(np.r_[left - m_left, right - m_right] ** 2)))
        jump = m_right - m_left
        if abs(jump) > max(_STEP_SIGMAS * scatter, _MIN_STEP_S):
            return (
                int(g[c - 1]),
                int(g[c]),
                (
                    f"the phase of the pulses jumps by {jump / beta:+.6f} s (modulo whole "
                    "seconds) there and stays "
                    f"(scatter {scatter / beta:.1e} s on either side)"
                ),
            )
    return None


def find_zda_step(
    t: FloatArray,
    labels: IntArray,
    good: BoolArray,
    z_t: FloatArray,
    label_offset: FloatArray,
    named: IntArray,
) -> tuple[int, int, str] | None:
    """Find a whole-second step of the local clock, which only the ZDAs show.

    ``label_offset`` is each ZDA's GPS second minus the grid count it names: one value
    for a log without a step. At least `_STEP_MIN_ZDAS` consecutive ZDAs (in time order)
    that agree on one value, followed by at least as many agreeing on another, mean the
    pulses' counts slipped by whole seconds between them (a wrong ZDA now and then
    breaks no run).

    Returns
    -------
    tuple or None
        The pulses named by the last ZDA of the first run and the first ZDA of the
        next, and the size of the step; None without such runs.
    """
    order = np.argsort(z_t, kind="stable")
    k = np.rint(label_offset[order])
    k[np.abs(label_offset[order] - k) > WHOLE_SECOND_TOLERANCE_S] = np.nan
    starts = np.r_[0, np.flatnonzero(~(k[1:] == k[:-1])) + 1]
    lengths = np.diff(np.r_[starts, len(k)])
    runs = [(int(a), int(n)) for a, n in zip(starts, lengths, strict=True) if n >= _STEP_MIN_ZDAS]
    runs = [(a, n) for a, n in runs if not np.isnan(k[a])]
    for (a0, n0), (a1, n1) in itertools.pairwise(runs):
        if k[a0] == k[a1]:
            continue
        last, first = order[a0 + n0 - 1], order[a1]
        by = float(k[a0] - k[a1])  # the count advanced by this much more than GPS time
        pulse_of = {int(labels[i]): int(i) for i in np.flatnonzero(good)}
        before = pulse_of.get(int(named[last]), int(np.searchsorted(t, z_t[last]) - 1))
        after = pulse_of.get(int(named[first]), int(np.searchsorted(t, z_t[first]) - 1))
        before, after = max(before, 0), max(after, 0)
        if after <= before:
            after = min(before + 1, len(t) - 1)
        return (
            before,
            after,
            (
                f"the {n0} ZDAs up to t_local_s={float(z_t[last])!r} and the {n1} from "
                f"t_local_s={float(z_t[first])!r} on name GPS seconds that say the local "
                f"clock jumped by {by:+.0f} s there (or the receiver's ZDAs are wrong from "
                "there)"
            ),
        )
    return None


def check_steps(
    t: FloatArray,
    phase_jump: tuple[int, int, str] | None,
    zda_step: tuple[int, int, str] | None,
) -> None:
    """Refuse a step found in the pulses' phase or in the ZDAs, naming it.

    A phase jump places a step best (a step inside the coarse tolerance tilts the grid,
    and the ZDAs' counts slip where the tilted grid crosses half a second, not at the
    step); where the ZDAs show a whole-second step at the same pulses, their account
    (the step in whole seconds) is given instead.

    Raises
    ------
    InputError
        `_step_error` for the step found.
    """
    found = phase_jump or zda_step
    if found is None:
        return
    if phase_jump is not None and zda_step is not None and zda_step[1] == phase_jump[1]:
        found = zda_step
    raise _step_error(t, *found)
