"""What the data can determine: each parameter estimated, weak or unobservable.

Read from the reduced normal matrix ``S`` (the information about the mount parameters
once every feature is free, `kinsync.calibration.adjustment`) before the solution:

- Each parameter's motion information ``M_i = sum w |d x / d theta_i|^2`` is what the
  returns' full 3-D motion would tell if the surfaces saw every direction; the seen
  fraction ``S_ii / M_ii`` is what is left once the features took their share. A
  heading boresight over flat ground moves the returns along the ground (the fraction
  is about the square of the vehicle's roll); a lever z over free planes is seen but
  taken by their offsets. Below `SEEN_FRACTION` the parameter is *unobservable*.
- Parameters the surfaces see may still be confounded with each other (a latency and
  a lever x at one speed): an eigenvalue of the correlation matrix of ``S`` below
  `NULL_EIGENVALUE` (`NULL_EIGENVALUE_FORMAL` when only the formal sigma follows).
  Of the parameters with a large share in that direction (|component| above
  `NULL_LOADING`) one is declared *unobservable* and held at its
  prior value, the first in `HOLD_ORDER` (latency, then lever arm, then boresight:
  lever arms are surveyed, a latency may come from a table test, a boresight cannot
  be measured any other way); its partners stay estimated, *given* the held prior, and
  the explanation says so.
- Each time, the held parameter leaves and the search repeats.
- After the solution, an estimate whose honest standard deviation exceeds
  `UNOBSERVABLE_THRESHOLDS` (1 deg, 10 cm, 10 ms) tells nothing (a heading from flat ground with a
  little roll): it is *unobservable*. When it is correlated beyond 0.9 with other
  estimates, the first of the group in `HOLD_ORDER` is held at its prior (a sphere
  seen at one range cannot tell a pitch boresight from a lever x: the lever arm, which
  a tape measures, is held, not the boresight); else the parameter itself. The rest is
  solved again (`HeldAfterSolution`). The sigma judged is the total: the data's and
  what the held values' stated sigma adds (`kinsync.calibration.held.hold_too_uncertain`);
  a lever arm known to 0.9 m leaves no boresight worth printing, however good the data.
- An estimated parameter is *weak* when its standard deviation exceeds the stated
  threshold (`WEAK_THRESHOLDS`, report units).

The correlations of the remaining parameters come from ``S^-1``. The advice says which
data would separate what could not be determined (SPEC section 8 and the patch-test
practice): lines in both directions, two speeds, a slope or a wall, a turn, a height
change.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._typing import FloatArray
from kinsync.calibration.parameters import PARAMETER_NAMES, REPORT_SCALE

__all__ = [
    "ADVICE",
    "HOLD_ORDER",
    "NULL_EIGENVALUE",
    "NULL_EIGENVALUE_FORMAL",
    "NULL_LOADING",
    "PARTNER_CORRELATION",
    "SEEN_FRACTION",
    "UNOBSERVABLE_THRESHOLDS",
    "WEAK_THRESHOLDS",
    "HeldAfterSolution",
    "Observability",
    "analyse",
    "correlation",
    "hold_after_solution",
    "status_of",
]

SEEN_FRACTION = 1e-4
"""Seen fraction of a parameter's motion below which the data do not determine it."""
NULL_EIGENVALUE = 1e-5
"""Smallest eigenvalue of the parameters' correlation matrix (from ``S``) below which
some of them cannot be told apart (a multiple correlation above 0.999995), when the
jackknife will judge the rest. Only true degeneracies fall below it (one speed without
attitude dynamics: about 1e-9): with millions of returns the formal information is
large, and a pair correlated at 0.9999 (a heading boresight and a lever y seen through
walls at 13 and 21 m) may still be well determined; whether it is, the honest sigma
says after the solution (`UNOBSERVABLE_THRESHOLDS`)."""
NULL_EIGENVALUE_FORMAL = 1e-3
"""The same when only the formal sigma will be reported (fewer lines than a jackknife
needs): the formal sigma cannot show that a near-degenerate pair is poorly determined
(it assumes independent errors), so a multiple correlation above 0.9995 is itself the
verdict."""
NULL_LOADING = 0.2
"""Share of a null direction above which a parameter takes part in it."""
HOLD_ORDER = (6, 5, 3, 4, 2, 1, 0)
"""Which parameter of a null direction is held first: latency, lever z, x, y, then the
heading, pitch and roll boresight."""

WEAK_THRESHOLDS = (0.02, 0.02, 0.02, 0.02, 0.02, 0.02, 1.0)
"""Standard deviation above which an estimate is weak (deg, deg, deg, m, m, m, ms)."""
UNOBSERVABLE_THRESHOLDS = (1.0, 1.0, 1.0, 0.1, 0.1, 0.1, 10.0)
"""Standard deviation above which an estimate is no estimate (deg, deg, deg, m, m, m,
ms): no better than what a crew knows without calibrating (a boresight from the
installation drawing, a lever arm from a tape, a latency from the system's data
sheet). After the solution such a parameter is held at its prior, as unobservable,
and the rest solved again."""

PARTNER_CORRELATION = 0.9
"""|correlation| above which two estimates lean on each other (`hold_after_solution`)."""

ADVICE = (
    "roll boresight: lines in both directions over the same flat ground",
    "pitch boresight: a slope, a roof or a wall across the line, in both directions",
    "heading boresight: walls seen from both directions, or a turn",
    "lever x: two speeds (it moves with the latency) and turns",
    "lever y: lines in both directions past walls",
    "lever z: a height change, or slopes and walls seen from both sides",
    "latency: two speeds in both directions, or turns and roll/pitch dynamics",
)
"""Which data would determine each parameter, in the order of the parameters."""


@dataclass(frozen=True)
class HeldAfterSolution:
    """A parameter held at its prior after the solution, and why.

    Attributes
    ----------
    index : int
        The parameter held.
    cause : int
        The parameter found too uncertain: ``index`` itself, or the one it cannot be
        told apart from (then ``index`` is the first of the two in `HOLD_ORDER`).
    std_report : float
        The honest sigma of ``cause`` (report units).
    partners : tuple of int
        Estimates correlated with ``index`` beyond 0.9: they stay, given its prior.
    reason : str
        Why, when it is not a sigma above `UNOBSERVABLE_THRESHOLDS` (e.g. the latency
        ran to the end of the lines' trajectories); empty otherwise.
    std_data : float
        When the held values' stated sigma took ``std_report`` (the total) above the
        threshold: the data's part of it (report units); NaN otherwise.
    limited_by : tuple of (int, float, float)
        Then the held values whose stated sigma did it: each with that sigma and the
        sigma that would bring ``cause`` within its threshold (report units).
    """

    index: int
    cause: int
    std_report: float
    partners: tuple[int, ...] = ()
    reason: str = ""
    std_data: float = math.nan
    limited_by: tuple[tuple[int, float, float], ...] = ()

    def explanation(self, estimated: Sequence[int] | None = None) -> str:
        """In words: what was too uncertain, what was held, what leans on the prior.

        ``estimated``: the parameters estimated in the end; partners not among them
        (held later) are not said to be estimated. None: every partner is.
        """
        name, cause = PARAMETER_NAMES[self.index], PARAMETER_NAMES[self.cause]
        if self.reason:
            return f"{name}: {self.reason}; held at its prior value"
        limit = UNOBSERVABLE_THRESHOLDS[self.cause]
        text = (
            f"{cause} is determined only to +-{self.std_report:.3g} by these data (more than "
            f"{limit:g})"
        )
        if self.limited_by:
            names = " and ".join(PARAMETER_NAMES[h] for h, _, _ in self.limited_by)
            text = (
                f"{cause} is determined only to +-{self.std_report:.3g} (more than {limit:g}): "
                f"these data give +-{self.std_data:.3g}, the rest is the stated sigma of the "
                f"held {names}"
            )
        if self.index == self.cause:
            text += ": held at its prior value"
        else:
            text += f", for it cannot be told apart from {name}: {name} held at its prior value"
        return text + _leaning(self.partners, estimated, "that prior")

    def held_advice(self, undetermined: Collection[int] = ()) -> str:
        """What would determine ``cause`` when held values' sigma limits it; else empty.

        ``undetermined``: held values the data could not determine (estimating them is
        no remedy).
        """
        if not self.limited_by:
            return ""
        known = " and ".join(
            f"{PARAMETER_NAMES[h]}{' known' * (k == 0)} to +-{need:.2g} instead of +-{stated:.2g}"
            for k, (h, stated, need) in enumerate(self.limited_by)
        )
        estimable = any(h not in undetermined for h, _, _ in self.limited_by)
        return (
            f"{PARAMETER_NAMES[self.cause]}: {known} (for a sigma within "
            f"{UNOBSERVABLE_THRESHOLDS[self.cause]:g})" + (", or estimated" * estimable)
        )


@dataclass(frozen=True)
class Observability:
    """Which parameters the data determine.

    Attributes
    ----------
    estimated : tuple of int
        Parameters kept for the solution.
    unobservable : tuple of int
        Parameters held at their prior values, one per null direction, in the order
        they were found.
    null_directions : tuple of tuple of (int, float)
        Each direction the data do not see: (parameter, component) pairs.
    held_after : tuple of HeldAfterSolution
        Parameters held after the solution (their honest sigma was too large).
    """

    estimated: tuple[int, ...]
    unobservable: tuple[int, ...]
    null_directions: tuple[tuple[tuple[int, float], ...], ...]
    held_after: tuple[HeldAfterSolution, ...] = ()

    def without(self, held: HeldAfterSolution) -> Observability:
        """The analysis with one more parameter held after the solution."""
        return Observability(
            estimated=tuple(i for i in self.estimated if i != held.index),
            unobservable=self.unobservable,
            null_directions=self.null_directions,
            held_after=(*self.held_after, held),
        )

    @property
    def held(self) -> tuple[int, ...]:
        """Every parameter held at its prior (found before or after the solution)."""
        return self.unobservable + tuple(h.index for h in self.held_after)

    def advice(self) -> tuple[str, ...]:
        """What would determine the parameters not determined, one line each.

        A parameter held because the held values' stated sigma took it beyond the
        threshold gets how well they would have to be known instead of which data
        would help (the data already determine it).
        """
        by_held = [h for h in self.held_after if h.limited_by]
        limited = {i for h in by_held for i in (h.index, h.cause)}
        by_data = set(self.unobservable) | {
            i for h in self.held_after if not h.limited_by for i in (h.index, h.cause)
        }
        need = tuple(h.held_advice(self.held) for h in by_held)
        return need + tuple(ADVICE[i] for i in sorted(by_data | (set(self.held) - limited)))

    def explanation(self) -> tuple[str, ...]:
        """Each null direction in words: what cannot be told apart, what was held.

        Each held parameter is named as held once, with the reason that finally held
        it; only the parameters estimated in the end are said to be estimated.
        """
        out = []
        for held, direction in zip(self.unobservable, self.null_directions, strict=True):
            names = [PARAMETER_NAMES[i] for i, _ in direction]
            if len(names) == 1:
                out.append(f"{names[0]} is not seen by the data (the features absorb it)")
            else:
                others = [i for i, _ in direction if i != held]
                out.append(
                    f"{' and '.join(names)} cannot be told apart by these data: "
                    f"{PARAMETER_NAMES[held]} held at its prior value"
                    + _leaning(others, self.estimated, "that prior", ",")
                )
        out.extend(self._held_after_explanation())
        return tuple(out)

    def _held_after_explanation(self) -> list[str]:
        """`HeldAfterSolution.explanation` of each, a cause held later told with it.

        A parameter held because its cause could not be told apart from it, whose cause
        was then held too (its sigma still too large): one sentence with the cause's last
        sigma, instead of one with a sigma since superseded and a second naming the cause
        again.
        """
        entries = self.held_after
        merged: dict[int, int] = {}  # a later entry -> the earlier one it is told with
        for k, h in enumerate(entries):
            if h.reason or h.limited_by or h.cause == h.index:
                continue
            later = next(
                (
                    m
                    for m in range(k + 1, len(entries))
                    if entries[m].index == h.cause
                    and entries[m].cause == h.cause
                    and not entries[m].reason
                    and not entries[m].limited_by
                    and m not in merged
                ),
                None,
            )
            if later is not None:
                merged[later] = k
        together = {k: m for m, k in merged.items()}
        out = []
        for k, h in enumerate(entries):
            if k in merged:
                continue
            if k not in together:
                out.append(h.explanation(self.estimated))
                continue
            last = entries[together[k]]
            name, cause = PARAMETER_NAMES[h.index], PARAMETER_NAMES[h.cause]
            partners = [j for j in (*h.partners, *last.partners) if j not in (h.index, h.cause)]
            out.append(
                f"{cause} is determined only to +-{last.std_report:.3g} by these data (more "
                f"than {UNOBSERVABLE_THRESHOLDS[h.cause]:g}), even with {name} held at its "
                f"prior value (the two cannot be told apart): both held at their prior values"
                + _leaning(dict.fromkeys(partners), self.estimated, "those priors")
            )
        return out


def _leaning(
    partners: Iterable[int], estimated: Sequence[int] | None, prior: str, sep: str = ";"
) -> str:
    """``"; a and b estimated as if that prior were right"`` for the partners estimated."""
    names = [PARAMETER_NAMES[j] for j in partners if estimated is None or j in estimated]
    if not names:
        return ""
    return f"{sep} {' and '.join(names)} estimated as if {prior} were right"


def _null(
    S: FloatArray, motion: FloatArray, candidates: list[int], null_eigenvalue: float
) -> tuple[tuple[int, float], ...] | None:
    """A direction of the candidates the data do not determine, or None.

    First a parameter the surfaces do not see (its seen fraction ``S_ii / M_ii`` below
    `SEEN_FRACTION`), then a group that cannot be told apart (the correlation matrix
    of ``S`` with an eigenvalue below ``null_eigenvalue``).
    """
    seen = np.diag(S) / np.maximum(motion, 1e-300)
    i = int(np.argmin(seen))
    if seen[i] < SEEN_FRACTION:
        return ((candidates[i], 1.0),)
    d = 1.0 / np.sqrt(np.maximum(np.diag(S), 1e-300))
    R = S * d[:, None] * d[None, :]
    w, v = np.linalg.eigh(0.5 * (R + R.T))
    if w[0] >= null_eigenvalue:
        return None
    vec = v[:, 0]
    members = [(candidates[j], float(vec[j])) for j in np.argsort(-np.abs(vec))]
    return tuple((j, c) for j, c in members if abs(c) >= NULL_LOADING)


def analyse(
    S: FloatArray,
    raw: FloatArray,
    estimated: tuple[int, ...],
    *,
    honest_sigma: bool = True,
) -> Observability:
    """Split the requested parameters into determined and unobservable ones.

    Parameters
    ----------
    S : ndarray, shape (k, k)
        Reduced normal matrix of the requested parameters ``estimated``.
    raw : ndarray, shape (k,)
        Their raw information ``diag(A)``.
    estimated : tuple of int
        The requested parameters (indices into the seven).
    honest_sigma : bool
        A jackknife sigma will follow (`NULL_EIGENVALUE`); False: only the formal one
        (`NULL_EIGENVALUE_FORMAL`).

    Returns
    -------
    Observability
    """
    keep = list(range(len(estimated)))
    dropped: list[int] = []
    directions = []
    while keep:
        sub = np.ix_(keep, keep)
        limit = NULL_EIGENVALUE if honest_sigma else NULL_EIGENVALUE_FORMAL
        direction = _null(S[sub], raw[keep], [estimated[i] for i in keep], limit)
        if direction is None:
            break
        directions.append(direction)
        members = {p for p, _ in direction}
        held = next(i for i in HOLD_ORDER if i in members)
        dropped.append(held)
        keep = [i for i in keep if estimated[i] != held]
    return Observability(
        estimated=tuple(estimated[i] for i in keep),
        unobservable=tuple(dropped),
        null_directions=tuple(directions),
    )


def correlation(covariance: FloatArray) -> FloatArray:
    """Correlation matrix of a covariance, shape (k, k)."""
    sd = np.sqrt(np.maximum(np.diag(covariance), 1e-300))
    out: FloatArray = covariance / sd[:, None] / sd[None, :]
    return out


def status_of(index: int, std_report: float) -> str:
    """``weak`` when a standard deviation (report units) exceeds its threshold."""
    return "weak" if not std_report <= WEAK_THRESHOLDS[index] else "estimated"


def hold_after_solution(
    estimated: tuple[int, ...],
    std: FloatArray,
    moved: Sequence[bool],
    covariance: FloatArray,
) -> HeldAfterSolution | None:
    """What to hold after a solution whose honest sigma is too large, if anything.

    The cause: the estimate furthest beyond its `UNOBSERVABLE_THRESHOLDS`, among those
    the data did not move beyond 3 sigma from their start (one they moved further is
    determined, if loosely: weak, kept). Held: the first in `HOLD_ORDER` of the cause
    and the estimates correlated with it beyond `PARTNER_CORRELATION`.

    Parameters
    ----------
    estimated : tuple of int
        The estimated parameters (k).
    std : ndarray, shape (k,)
        Their honest standard deviations (internal units: rad, m, s).
    moved : sequence of bool, length k
        Whether the data moved each beyond 3 sigma from where the solve started: the
        prior, or a yaw a search chose (all False in a plan).
    covariance : ndarray, shape (k, k)
        Their covariance (any units: only the correlations are used).

    Returns
    -------
    HeldAfterSolution or None
    """
    cause, ratio_max = -1, 1.0
    for j, i in enumerate(estimated):
        ratio = float(std[j]) * REPORT_SCALE[i] / UNOBSERVABLE_THRESHOLDS[i]
        if ratio > ratio_max and not moved[j]:
            cause, ratio_max = i, ratio
    if cause < 0:
        return None
    r = correlation(covariance)

    def group(i: int) -> tuple[int, ...]:
        j = estimated.index(i)
        return tuple(
            p for m, p in enumerate(estimated) if m != j and abs(r[j, m]) > PARTNER_CORRELATION
        )

    held = next(i for i in HOLD_ORDER if i in {cause, *group(cause)})
    std_report = float(std[estimated.index(cause)]) * REPORT_SCALE[cause]
    return HeldAfterSolution(held, cause, std_report, group(held))
