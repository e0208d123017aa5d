"""Sphere targets found in each line and matched across lines: one centre for all passes.

With the starting mount each line is georeferenced into the local frame and searched
with `kinsync.fit.segment.segment_sphere` (RANSAC among clutter: floor, stand, stray
returns, then a robust fit): the known radius when given, else a radius within
``radius_bounds_m``. Up to ``max_spheres_per_line`` spheres per line (each search
removes the previous sphere's returns). Sightings from different lines whose centres
lie within ``match_distance_m`` of each other are one target: a wrong mount moves a
sphere between passes by decimetres, rarely by metres. Every target must be seen by at
least two lines. Each (target, line) keeps the returns within a band of the fitted
surface, at most ``max_points_per_line`` of them (seeded).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync.calibration.adjustment import Observation
from kinsync.calibration.features import SphereFeature, thin_returns
from kinsync.calibration.model import LineModel, LocalFrame
from kinsync.errors import InputError, KinsyncError
from kinsync.fit.segment import segment_sphere

__all__ = ["SphereOptions", "SphereTargets", "find_sphere_targets"]


@dataclass(frozen=True)
class SphereOptions:
    """Settings of the sphere search.

    Attributes
    ----------
    radius_m : float or None
        Known radius (m); None: fitted, one radius per target for all its passes.
    radius_bounds_m : tuple of 2 float
        Plausible radii (m) when the radius is fitted.
    max_spheres_per_line : int
        Spheres searched per line.
    min_points : int
        Returns a sighting needs.
    match_distance_m : float
        Largest distance between the centres of two sightings of one target (m).
    band_m : float
        Returns within this of the fitted surface are kept (m).
    max_points_per_line : int
        Returns kept per (target, line).
    min_lines : int
        Lines that must see a target.
    seed : int
        Seed of RANSAC and of the thinning.
    """

    radius_m: float | None = None
    radius_bounds_m: tuple[float, float] = (0.05, 1.0)
    max_spheres_per_line: int = 3
    min_points: int = 30
    match_distance_m: float = 3.0
    band_m: float = 0.05
    max_points_per_line: int = 1000
    min_lines: int = 2
    seed: int = 0

    def __post_init__(self) -> None:
        if self.radius_m is not None and not (math.isfinite(self.radius_m) and self.radius_m > 0.0):
            msg = f"--sphere-radius-m must be a positive number of metres, got {self.radius_m!r}"
            raise InputError(msg)
        lo, hi = self.radius_bounds_m
        if not (0.0 < lo < hi and math.isfinite(hi)):
            msg = f"sphere radius bounds must be 0 < lo < hi, got {self.radius_bounds_m!r}"
            raise InputError(msg)


@dataclass(frozen=True, eq=False)
class SphereTargets:
    """Targets found, ready for the adjustment.

    Attributes
    ----------
    features : tuple of SphereFeature
        One sphere per target: the mean of its sightings' centres, their median radius
        (or the known one).
    observations : tuple of Observation
        The returns of each line on each target.
    n_sightings : int
        Spheres found in the lines before matching.
    """

    features: tuple[SphereFeature, ...]
    observations: tuple[Observation, ...]
    n_sightings: int


@dataclass(frozen=True)
class _Sighting:
    line: int
    centre: FloatArray
    radius: float
    index: IntArray


def _search_line(li: int, x: FloatArray, opt: SphereOptions) -> list[_Sighting]:
    left = np.flatnonzero(np.all(np.isfinite(x), axis=1))
    out = []
    for _ in range(opt.max_spheres_per_line):
        if left.size < opt.min_points:
            break
        try:
            fit = segment_sphere(
                x[left],
                radius_m=opt.radius_m,
                radius_bounds_m=None if opt.radius_m is not None else opt.radius_bounds_m,
                seed=opt.seed,
            )
        except KinsyncError:
            break
        if fit.n_points < opt.min_points:
            break
        dist = np.abs(np.linalg.norm(x[left] - fit.center_m, axis=1) - fit.radius_m)
        near = left[dist <= opt.band_m]
        out.append(_Sighting(li, fit.center_m, fit.radius_m, near))
        left = left[dist > max(opt.band_m, 3.0 * fit.residual_rms_m)]
    return out


def _match(sightings: list[_Sighting], opt: SphereOptions) -> list[list[_Sighting]]:
    """Group sightings whose centres are close (greedy, largest groups first)."""
    groups: list[list[_Sighting]] = []
    for s in sightings:
        for g in groups:
            centre = np.mean([m.centre for m in g], axis=0)
            if np.linalg.norm(s.centre - centre) <= opt.match_distance_m and all(
                m.line != s.line for m in g
            ):
                g.append(s)
                break
        else:
            groups.append([s])
    return [g for g in groups if len({m.line for m in g}) >= opt.min_lines]


def find_sphere_targets(
    models: Sequence[LineModel],
    values: FloatArray,
    frame: LocalFrame,
    options: SphereOptions | None = None,
) -> SphereTargets:
    """Find sphere targets seen by several lines, with the returns of each line on each.

    Parameters
    ----------
    models : sequence of LineModel
        The lines.
    values : ndarray, shape (7,)
        Starting mount parameters (rad, m, s).
    frame : LocalFrame
        Frame of the features.
    options : SphereOptions, optional

    Returns
    -------
    SphereTargets

    Raises
    ------
    InputError
        No sphere found, or none seen by two lines.
    """
    opt = options or SphereOptions()
    points = [m.points(None, values, frame) for m in models]
    sightings = [s for li, x in enumerate(points) for s in _search_line(li, x, opt)]
    if not sightings:
        msg = (
            "no sphere found in any line: check --sphere-radius-m, that the files hold "
            "returns from the targets, and the starting mount"
        )
        raise InputError(msg)
    groups = _match(sightings, opt)
    if not groups:
        msg = (
            f"{len(sightings)} sphere sighting(s) found but none of them seen by "
            f"{opt.min_lines} lines within {opt.match_distance_m:g} m of each other: "
            "the lines do not pass the same targets, or the starting mount is far off"
        )
        raise InputError(msg)
    features: list[SphereFeature] = []
    observations: list[Observation] = []
    for fid, group in enumerate(groups):
        per_line = []
        for s in group:
            line = models[s.line].line
            idx = thin_returns(
                s.index, opt.max_points_per_line, opt.seed, line.t_s, line.xyz_scanner_m
            )
            per_line.append((s.line, idx))
        # The start: the mean of the sightings' centres (a wrong mount scatters them;
        # one fit through every pass's returns would not converge), their median radius.
        radius = (
            opt.radius_m
            if opt.radius_m is not None
            else float(np.median([s.radius for s in group]))
        )
        features.append(
            SphereFeature(
                centre_m=np.mean([s.centre for s in group], axis=0),
                radius_m=radius,
                radius_known=opt.radius_m is not None,
            )
        )
        observations.extend(Observation(li, fid, idx) for li, idx in per_line)
    return SphereTargets(
        features=tuple(features), observations=tuple(observations), n_sightings=len(sightings)
    )
