"""Method B: what the sync points themselves say when they are wrong.

Sync-point coordinates are the one input that the matching cannot check for itself: a
point surveyed in another datum or epoch, or a height in feet or orthometric, moves its
crossings, and the clock is fitted to whatever still matches. These checks turn what
the data show into warnings and hints (see `kinsync.sync.object_space`):

- a sighting left unmatched near a crossing of a sync point that the clock leaves out
  (`near_crossings`, `near_crossings_text`): the point was seen, a little off, and the
  clock rests on the others, so it may be off too;
- a sync point never crossed within reach of the scanner, and two sync points at one
  place (`sync_point_notes`);
- no clock at all, and no sighting where the geometry puts any sync point
  (`no_assignment_text`).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from kinsync.sync.clock_line import compatible_crossings
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.crossings import TRACK_HALF_S, Crossing, CrossingSearch
from kinsync.sync.scan import SyncPoints
from kinsync.sync.sightings import Sighting
from kinsync.trajectory_gaps import GAP_ADVICE, gap_threshold_text

__all__ = [
    "COINCIDENT_M",
    "NEAR_CROSSING_FLOOR_M",
    "NEAR_CROSSING_M",
    "NearCrossing",
    "near_crossings",
    "near_crossings_text",
    "no_assignment_text",
    "sync_point_notes",
]

NEAR_CROSSING_M = 2.0
"""An unmatched sighting whose sync-point crossing the clock puts within this distance
along the track (m; the sweep of the scan plane over the point, ``|d'| dt``) is taken
for a sighting of that point, a little off: sync-point coordinates in another datum
or epoch are off by 0.1 to 2 m. Within at most `kinsync.sync.crossings.TRACK_HALF_S`
in time, so that a slow sweep in a turn does not reach far."""

NEAR_CROSSING_FLOOR_M = 0.1
"""...but not within this distance (m): a sighting's own error explains that much (a
sphere fit off by two or three profiles on a plane slanted 20 deg, where the sweep is
slow: 0.05 m on exact data)."""

COINCIDENT_M = 0.1
"""Two sync points closer than this (m) are one target listed twice: the centres of two
spheres lie a diameter apart at least."""


@dataclass(frozen=True)
class NearCrossing:
    """An unmatched sighting near a crossing of a sync point, off the clock.

    Attributes
    ----------
    name : str
        The sync point.
    profile : float
        The sighting's sub-profile number.
    offset_profiles : float
        Where the clock puts the crossing minus the sighting, along the clock's
        abscissa ``n + phi / 2 pi`` (profiles; positive: the sighting came first).
    offset_s : float
        The same in time (s).
    offset_m : float
        The same along the track (m): the scan plane's sweep over the point in that
        time, ``|d'| offset_s``.
    """

    name: str
    profile: float
    offset_profiles: float
    offset_s: float
    offset_m: float

    def as_document(self) -> dict[str, Any]:
        """JSON-ready dict (``near_crossing_of`` of an unmatched sighting)."""
        return {
            "name": self.name,
            "offset_profiles": self.offset_profiles,
            "offset_s": self.offset_s,
            "offset_m": self.offset_m,
        }


def near_crossings(
    unmatched: Sequence[Sighting],
    crossings: Sequence[Crossing],
    claimed: Collection[int],
    cfg: ObjectSpaceConfig,
    t0_s: float,
    period_s: float,
) -> tuple[NearCrossing | None, ...]:
    """For each unmatched sighting, the unused crossing it is a sighting of, a little off.

    Parameters
    ----------
    unmatched : sequence of Sighting
        The sightings the clock leaves out.
    crossings : sequence of Crossing
        Every crossing found.
    claimed : collection of int
        Indices into ``crossings`` matched to a sighting by the clock (never named).
    cfg : ObjectSpaceConfig
        ``angle_gate_rad`` and ``range_gate_m``: the sighting must lie where the
        crossing puts the point.
    t0_s, period_s : float
        The clock (s).

    Returns
    -------
    tuple of (NearCrossing or None)
        One per unmatched sighting: the compatible crossing, not claimed, that the
        clock puts within `NEAR_CROSSING_M` along the track, but not within
        `NEAR_CROSSING_FLOOR_M`, and within `TRACK_HALF_S` in time (the nearest of
        several), None where there is none.
    """
    out: list[NearCrossing | None] = []
    for s, js in zip(unmatched, compatible_crossings(unmatched, crossings, cfg), strict=True):
        best: NearCrossing | None = None
        for j in js.tolist():
            if j in claimed:
                continue
            c = crossings[j]
            offset_s = c.t_s - (t0_s + period_s * s.x)
            offset_m = abs(c.rate_m_s * offset_s)
            if abs(offset_s) > TRACK_HALF_S or not (
                NEAR_CROSSING_FLOOR_M <= offset_m <= NEAR_CROSSING_M
            ):
                continue
            if best is None or offset_m < best.offset_m:
                best = NearCrossing(c.name, s.profile, offset_s / period_s, offset_s, offset_m)
        out.append(best)
    return tuple(out)


def near_crossings_text(source: str, near: Sequence[NearCrossing | None]) -> str | None:
    """The warning for unmatched sightings near sync-point crossings, None without any.

    Parameters
    ----------
    source : str
        The sync points' file, for the message.
    near : sequence of (NearCrossing or None)
        `near_crossings`' answer.

    Returns
    -------
    str or None
        Each sync point with its sightings (profile, and how far off in profiles,
        seconds and metres along the track), and what to check.
    """
    found = [n for n in near if n is not None]
    if not found:
        return None
    by_point: dict[str, list[NearCrossing]] = {}
    for n in found:
        by_point.setdefault(n.name, []).append(n)
    parts = [
        f"{name!r} "
        + ", ".join(
            f"at profile {n.profile:.1f}, {abs(n.offset_profiles):.1f} profiles "
            f"({abs(n.offset_s):.3f} s, {n.offset_m:.2f} m along the track)"
            for n in items
        )
        for name, items in by_point.items()
    ]
    return (
        f"{source}: {len(found)} sighting(s) lie near crossings of sync points that the clock "
        "leaves out, beyond its match gate, off from where it puts the crossing by: "
        f"{'; '.join(parts)}; these are probably the sync points themselves, seen where their "
        "coordinates do not put them: the coordinates (datum, epoch, height), the mount or "
        "the trajectory there may be off by about that much, and the clock, which rests on "
        "the other sightings, with them: check them"
    )


def sync_point_notes(
    points: SyncPoints, search: CrossingSearch, n_crossings: Mapping[str, int], max_range_m: float
) -> list[str]:
    """Warnings about the sync points themselves: never crossed, or two at one place.

    Parameters
    ----------
    points : SyncPoints
        The sync points (their `SyncPoints.label` names them in messages).
    search : CrossingSearch
        What the crossing search found (its ``distance_m`` and ``in_gaps``).
    n_crossings : Mapping of str to int
        Timed crossings per sync point.
    max_range_m : float
        Farthest crossing considered (m).

    Returns
    -------
    list of str
        One message per sync point that the scan plane never sweeps within
        ``max_range_m`` of the scanner (outside the trajectory's data gaps), and per
        pair of sync points closer than `COINCIDENT_M`.
    """
    notes: list[str] = []
    gapped = {c.name for c in search.in_gaps}
    for i, name in enumerate(points.names):
        if n_crossings.get(name, 0) or name in gapped:
            continue
        away = (
            f" (it lies {search.distance_m[i]:.0f} m from the nearest trajectory position)"
            if search.distance_m
            else ""
        )
        notes.append(
            f"{points.source}: sync point {points.label(i)} is never crossed by the scan "
            f"plane within {max_range_m:g} m of the scanner{away}, so it times nothing: "
            "check its coordinates, or leave it out"
        )
    pos = points.pos_ecef_m()
    for i, k in sorted(cKDTree(pos).query_pairs(COINCIDENT_M)):
        gap_m = float(np.linalg.norm(pos[i] - pos[k]))
        notes.append(
            f"{points.source}: sync points {points.label(i)} and {points.label(k)} lie "
            f"{gap_m:.3f} m apart, closer than two targets can ({COINCIDENT_M:g} m): one "
            "target listed twice, whose sightings go to one of the names; remove the copy or "
            "correct its coordinates"
        )
    return notes


def no_assignment_text(
    points: SyncPoints,
    sightings: Sequence[Sighting],
    crossings: Sequence[Crossing],
    search: CrossingSearch,
    cfg: ObjectSpaceConfig,
) -> str:
    """Why no assignment of sightings to crossings gives a period within the prior's window.

    Parameters
    ----------
    points : SyncPoints
        The sync points (their file names the message).
    sightings, crossings : sequence of Sighting, Crossing
        All sightings and crossings found.
    search : CrossingSearch
        The crossing search (sync points never crossed, crossings in data gaps).
    cfg : ObjectSpaceConfig
        The prior, its tolerance and the gates.

    Returns
    -------
    str
        The message: counts, the sync points never crossed, crossings left out in data
        gaps, and what to check. When fewer than two sightings lie where the geometry
        puts a sync point (mirror angle and range within the gates), no clock can be
        fitted whatever the prior: it says where the crossings put the sync points and
        where the sightings lie, and that the sync-point coordinates or the mount are
        wrong.
    """
    crossed = {c.name for c in crossings}
    never = [n for n in points.names if n not in crossed]
    return (
        f"{points.source}: no assignment of the {len(sightings)} sighting(s) to the "
        f"{len(crossings)} crossing(s) gives a period within {cfg.period_tolerance:g} "
        f"(relative) of {cfg.period_prior_s!r} s"
        + (f"; sync point(s) {never} are never crossed" if never else "")
        + (
            f"; {len(search.in_gaps)} possible crossing(s) in data gaps of the trajectory "
            f"({gap_threshold_text(search.max_gap_s)}) left out: {GAP_ADVICE}"
            if search.in_gaps
            else ""
        )
        + (
            _not_seen_hint(sightings, crossings, cfg)
            or ": check --period-prior-s/--period-tolerance, the mount and the sync points"
        )
    )


def _not_seen_hint(
    sightings: Sequence[Sighting], crossings: Sequence[Crossing], cfg: ObjectSpaceConfig
) -> str:
    """Where crossings and sightings lie when fewer than two sightings match any, else ``""``."""
    compat = compatible_crossings(sightings, crossings, cfg)
    n_seen = sum(js.size > 0 for js in compat)
    if n_seen >= 2 or not sightings or not crossings:
        return ""

    def spread(rng: Sequence[float], ang: Sequence[float]) -> str:
        deg = np.degrees(ang)
        return (
            f"{min(rng):.1f} to {max(rng):.1f} m from the scanner at mirror angles "
            f"{float(np.min(deg)):.0f} to {float(np.max(deg)):.0f} deg"
        )

    seen = "none" if n_seen == 0 else "only 1"
    return (
        f"; {seen} of the {len(sightings)} sightings lies where the scan plane crosses a sync "
        f"point (mirror angle within {math.degrees(cfg.angle_gate_rad):g} deg and range "
        f"within {cfg.range_gate_m:g} m): the crossings put the sync points "
        f"{spread([c.range_m for c in crossings], [c.angle_rad for c in crossings])}, the "
        f"sightings lie {spread([s.range_m for s in sightings], [s.angle_rad for s in sightings])}"
        ": the sync-point coordinates (heights too: ellipsoidal, in metres, not orthometric "
        "or in feet) or the mount (lever arm, boresight, [profiler] azimuth_deg) are wrong"
    )
