"""Method A: passes paired by rate and axis, and the passes left out of the estimate.

`pair_groups` pools the passes per signed rate about one axis and pairs the pools at
+omega and -omega; `RejectedPass` is a pass left out, with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from kinsync.errors import InputError
from kinsync.latency.passes import SpherePass

__all__ = ["FittedPool", "RejectedPass", "left_without_partner", "pair_groups"]

_RATE_KEY_DECIMALS = 6
_AXIS_KEY_DECIMALS = 3


@dataclass(frozen=True)
class RejectedPass:
    """A pass left out of the estimate because it holds no usable sphere.

    Attributes
    ----------
    source : str
        Where the pass came from (its file).
    rate_deg_s : float
        Its signed table rate (deg/s).
    n_points : int
        Points in the pass (sphere and clutter).
    n_sphere_points : int
        Points of the pass on the sphere fitted at its rate (0 when none was found).
    reason : str
        Why it was left out, in words.
    """

    source: str
    rate_deg_s: float
    n_points: int
    n_sphere_points: int
    reason: str

    def as_document(self) -> dict[str, Any]:
        """JSON-ready form (an entry of ``rejected_passes``)."""
        return {
            "file": self.source,
            "rate_deg_s": self.rate_deg_s,
            "n_points": self.n_points,
            "n_sphere_points": self.n_sphere_points,
            "reason": self.reason,
        }


def _group_passes(
    passes: Sequence[SpherePass],
) -> dict[tuple[float, tuple[float, float, float]], list[SpherePass]]:
    groups: dict[tuple[float, tuple[float, float, float]], list[SpherePass]] = {}
    for p in passes:
        axis = np.asarray(p.axis_ned)
        rate = p.rate_deg_s
        # Canonical axis (first non-zero component positive) so -w about a and +w about -a
        # land in one pair.
        if axis[np.flatnonzero(np.abs(axis) > 1e-9)[0]] < 0:
            axis, rate = -axis, -rate
        key_axis = tuple(float(v) for v in np.round(axis, _AXIS_KEY_DECIMALS))
        key = (round(rate, _RATE_KEY_DECIMALS), (key_axis[0], key_axis[1], key_axis[2]))
        groups.setdefault(key, []).append(p)
    return groups


def pair_groups(
    passes: Sequence[SpherePass],
) -> tuple[list[tuple[list[SpherePass], list[SpherePass]]], list[float], list[RejectedPass]]:
    """Pools at +omega and -omega paired by rate and axis; rates with one sign only.

    Also the passes at those rates, each left out with the reason (`_never_paired`).
    """
    groups = _group_passes(passes)
    pairs: list[tuple[list[SpherePass], list[SpherePass]]] = []
    unpaired: list[float] = []
    for (rate, axis), group in sorted(groups.items()):
        if rate <= 0:
            continue
        opposite = groups.get((round(-rate, _RATE_KEY_DECIMALS), axis))
        if opposite is None:
            unpaired.append(rate)
        else:
            pairs.append((group, opposite))
    unpaired += [
        -r for (r, a) in groups if r < 0 and (round(-r, _RATE_KEY_DECIMALS), a) not in groups
    ]
    if not pairs:
        rates = sorted({p.rate_deg_s for p in passes})
        msg = (
            f"no table rate has passes of both signs (rates found: {rates} deg/s); "
            "Method A needs clockwise and counter-clockwise passes at the same rate"
        )
        raise InputError(msg)
    return pairs, unpaired, _never_paired(passes, pairs)


def _never_paired(
    passes: Sequence[SpherePass], pairs: list[tuple[list[SpherePass], list[SpherePass]]]
) -> list[RejectedPass]:
    """The passes at a rate given with one sign only, left out with the reason."""
    paired = {id(p) for pair in pairs for side in pair for p in side}
    return [
        RejectedPass(
            p.source,
            p.rate_deg_s,
            p.n_points,
            0,
            f"no pass at {-p.rate_deg_s:+g} deg/s about the same axis to pair it with: "
            "Method A needs passes of both signs at a rate",
        )
        for p in passes
        if id(p) not in paired
    ]


class FittedPool(Protocol):
    """What `left_without_partner` reads of a fitted pool (`kinsync.latency.sphere.PoolFit`)."""

    @property
    def rate_deg_s(self) -> float:
        """Signed table rate (deg/s)."""
        ...

    @property
    def sources(self) -> tuple[str, ...]:
        """Where the pooled passes came from."""
        ...

    @property
    def n_points_per_pass(self) -> tuple[int, ...]:
        """Points of each pass used in the pool's fit."""
        ...


def left_without_partner(pool: FittedPool | None, side: Sequence[SpherePass]) -> list[RejectedPass]:
    """The passes of a fitted pool left out because the opposite sign's hold no sphere.

    Parameters
    ----------
    pool : PoolFit or None
        The pool fitted at one sign (`FittedPool`); None (the pool that failed, its passes rejected)
        gives none.
    side : sequence of SpherePass
        The passes given at that sign.
    """
    if pool is None:
        return []
    reason = (
        f"the passes at {-pool.rate_deg_s:+g} deg/s hold no usable sphere (see the rejected "
        "passes): Method A needs passes of both signs at a rate"
    )
    remaining = list(side)
    left = []
    for source, n_sphere in zip(pool.sources, pool.n_points_per_pass, strict=True):
        p = remaining.pop(next(k for k, q in enumerate(remaining) if q.source == source))
        left.append(RejectedPass(p.source, p.rate_deg_s, p.n_points, n_sphere, reason))
    return left
