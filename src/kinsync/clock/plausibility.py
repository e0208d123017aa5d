"""Plausibility checks of a clock fit: signs that its answer or its sigma is wrong.

A clock fit can come out whole or part seconds off, or with a sigma far too small,
while every pulse and ZDA pairs up: the signs lie in figures no step of the fit
refuses on. Each check here returns a note (plain words, one line) or None;
`kinsync.clock.fit` issues the notes as `kinsync.errors.KinsyncWarning` warnings.

- `sentence_spacing_note`: NMEA sentences arriving closer together than their length
  takes to send at the stated baud (``--baud`` lower than the port's rate, or tags
  taken in batches): each ZDA's transmission start, hence the edge it names, is off.
- `zda_delay_note`: under ``"preceding"``, ZDAs starting more than 0.5 s after the
  edge they name (the falling edge tagged, a too low baud, the wrong convention).
- `pulse_scatter_note`: pulses scattered about the fitted line by more than any PPS
  tagging does (1 ms rms): a spurious pulse taken for a grid pulse.
- `residual_structure_note`: residuals that follow each other (oscillator wander):
  the least-squares sigma, which assumes independent pulse jitter, is too small.
"""

from __future__ import annotations

import numpy as np

from kinsync._typing import FloatArray

__all__ = [
    "LATEST_ZDA_DELAY_S",
    "PLAUSIBLE_PULSE_RMS_S",
    "pulse_scatter_note",
    "residual_structure_note",
    "sentence_spacing_note",
    "zda_delay_note",
]

LATEST_ZDA_DELAY_S = 0.5
"""Latest plausible start of a ZDA after the edge it names (s, ``"preceding"``)."""

PLAUSIBLE_PULSE_RMS_S = 1e-3
"""Largest plausible RMS of the pulses about the fitted line (s): software tagging of
a PPS edge jitters by tens of microseconds, an interrupt under load by a millisecond."""

_TOO_CLOSE = 0.5
"""A sentence that arrives sooner after the one before than this fraction of its own
transmission time at the stated baud contradicts that baud."""
_MIN_TOO_CLOSE = 3
_TOO_CLOSE_SHARE = 0.25
_STRUCTURE_Z = 5.0
"""Durbin-Watson statistic this many of its standard deviations (``2 / sqrt(n)``)
below 2 marks the residuals as correlated."""
_MIN_STRUCTURE_PULSES = 20


def sentence_spacing_note(
    t_local_s: FloatArray,
    n_bytes: FloatArray,
    lines: list[int],
    seconds_per_byte: float,
    baud: float,
    source: str,
) -> str | None:
    """Note sentences arriving closer together than the stated baud lets them.

    Each sentence is tagged at the end of its reception; the next one cannot end
    sooner than its own transmission time later.

    Parameters
    ----------
    t_local_s : ndarray, shape (L,)
        Arrival times of the log's lines, in file order (s, local clock).
    n_bytes : ndarray, shape (L,)
        Bytes of each line on the wire (``len(sentence) + 2``).
    lines : list of int, length L or 0
        File line of each (empty when not known).
    seconds_per_byte : float
        Time one byte takes at the stated line rate and frame (s).
    baud : float
        The stated line rate (bit/s), for the message.
    source : str
        The NMEA log, for the message.
    """
    if len(t_local_s) < 2:
        return None
    gap_s = np.diff(t_local_s)
    need_s = n_bytes[1:] * seconds_per_byte
    close = (gap_s >= 0.0) & (gap_s < _TOO_CLOSE * need_s)
    n_close = int(np.count_nonzero(close))
    if n_close < _MIN_TOO_CLOSE or n_close < _TOO_CLOSE_SHARE * len(gap_s):
        return None
    i = int(np.flatnonzero(close)[0])
    where = f"line {lines[i + 1]}" if lines else f"sentence {i + 2}"
    return (
        f"{source}: {n_close} of {len(gap_s)} NMEA sentences arrived sooner after the one "
        f"before than their length takes to send at --baud {baud:g} (e.g. {where}, "
        f"{int(n_bytes[i + 1])} bytes, {gap_s[i] * 1e3:.3g} ms after the line before, where "
        f"{need_s[i] * 1e3:.3g} ms are needed): the port runs faster than --baud says, or "
        "the logger tags lines in batches. Each ZDA's start, and so the second it names, is "
        "worked out from --baud: give the port's line rate, or the answer may be a second off"
    )


def zda_delay_note(zda_delay_s: float, convention: str, baud: float) -> str | None:
    """Note ZDAs that seem to start more than `LATEST_ZDA_DELAY_S` after their edge."""
    if convention != "preceding" or zda_delay_s <= LATEST_ZDA_DELAY_S:
        return None
    return (
        f"the ZDAs start {zda_delay_s * 1e3:.0f} ms after the pulse edge they name (median), "
        f"later than a receiver sends them (within {LATEST_ZDA_DELAY_S * 1e3:.0f} ms): the "
        "offset is most likely a fraction of a second or a whole second off. Check the PPS "
        "edge (a log of the falling edge, the wrong PPS polarity, puts every pulse a pulse "
        f"width late), --baud ({baud:g}; lower than the port's rate makes each ZDA seem to "
        "start earlier) and --convention (following, if the ZDA names the next edge)"
    )


def pulse_scatter_note(residual_rms_s: float, n_pulses: int) -> str | None:
    """Note pulses scattered about the line by more than `PLAUSIBLE_PULSE_RMS_S` rms."""
    if residual_rms_s <= PLAUSIBLE_PULSE_RMS_S:
        return None
    return (
        f"the {n_pulses} pulses used scatter {residual_rms_s * 1e3:.3g} ms rms about the "
        f"fitted line, more than PPS tagging does (under {PLAUSIBLE_PULSE_RMS_S * 1e3:g} ms): "
        "a spurious pulse was most likely taken for a pulse of the 1 s grid, and offset and "
        "drift are off; check the pulse log (a longer log tells such pulses apart)"
    )


def residual_structure_note(residuals_s: FloatArray, resolution_s: float) -> str | None:
    """Note residuals that follow each other (Durbin-Watson well below 2).

    Independent residuals give ``DW = sum(diff(r)**2) / sum(r**2)`` near 2 with a
    standard deviation near ``2 / sqrt(n)``; residuals that drift together (the clock's
    rate wanders) give DW near 0. The least-squares sigma assumes independent ones.

    Parameters
    ----------
    residuals_s : ndarray, shape (K,)
        Residuals of the good pulses in time order (s).
    resolution_s : float
        Float64 step of the times (s): residuals within it are rounding, whose
        pattern says nothing of the clock.
    """
    r = np.asarray(residuals_s, dtype=np.float64)
    n = len(r)
    rss = float(np.sum(r * r))
    if n < _MIN_STRUCTURE_PULSES or rss <= n * resolution_s**2:
        return None
    dw = float(np.sum(np.diff(r) ** 2)) / rss
    if (2.0 - dw) * np.sqrt(n) / 2.0 < _STRUCTURE_Z:
        return None
    rho = 1.0 - dw / 2.0
    return (
        f"the pulses' residuals follow each other (lag-1 correlation {rho:.2f}, "
        f"Durbin-Watson {dw:.2f} where independent jitter gives 2): the local clock's rate "
        "wanders, which one offset and drift do not follow, and their sigmas (and the mapped "
        "times') count pulse jitter only, so they are too small; fit with --piecewise to "
        "follow the wander between pulses"
    )
