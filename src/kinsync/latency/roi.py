"""Region of interest of Method A: a box that keeps the sphere and leaves out clutter.

`crop_passes` keeps the points of each `SpherePass` inside an axis-aligned box of the
table-centred NED frame (the frame of the pass files' ``x_m, y_m, z_m``) and counts, in
a `RoiCrop`, what each pass lost, so that nothing is left out unreported.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from kinsync._text import counted
from kinsync.errors import InputError
from kinsync.latency.passes import SpherePass

__all__ = [
    "ROI_OPTION",
    "RoiBox",
    "RoiCrop",
    "checked_roi",
    "crop_passes",
    "roi_text",
]

RoiBox = tuple[float, float, float, float, float, float]
"""``(x_min, y_min, z_min, x_max, y_max, z_max)``, table-centred NED (m)."""

ROI_OPTION = "--roi-m"
"""The command-line option that gives the region of interest (named in messages)."""
_ROI_NAMES = f"roi_ned_m, {ROI_OPTION}"
"""The argument and the option that give it, as errors name them."""

_SHOWN = 3


def checked_roi(box: Sequence[float]) -> RoiBox:
    """The box as six floats, each minimum below its maximum.

    Parameters
    ----------
    box : sequence of 6 float
        ``(x_min, y_min, z_min, x_max, y_max, z_max)``, table-centred NED (m).

    Raises
    ------
    InputError
        Not six finite numbers, or a minimum not below its maximum.
    """
    try:
        values = [float(v) for v in box]
    except (TypeError, ValueError) as err:
        msg = f"region of interest ({_ROI_NAMES}): expected 6 numbers, got {box!r}"
        raise InputError(msg) from err
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        msg = (
            f"region of interest ({_ROI_NAMES}): expected 6 finite numbers "
            f"xmin,ymin,zmin,xmax,ymax,zmax (m), got {box!r}"
        )
        raise InputError(msg)
    for axis in range(3):
        lo, hi = values[axis], values[axis + 3]
        if not lo < hi:
            name = "xyz"[axis]
            msg = (
                f"region of interest ({_ROI_NAMES}): {name}min {lo:g} m must be below "
                f"{name}max {hi:g} m (the order is xmin,ymin,zmin,xmax,ymax,zmax)"
            )
            raise InputError(msg)
    return (values[0], values[1], values[2], values[3], values[4], values[5])


def roi_text(box: Sequence[float]) -> str:
    """The box in words, e.g. ``x 1.2 to 1.8, y -0.3 to 0.3, z -0.3 to 0.4 m``.

    ``box`` is ``(x_min, y_min, z_min, x_max, y_max, z_max)`` (m).
    """
    return ", ".join(f"{'xyz'[k]} {box[k]:.4g} to {box[k + 3]:.4g}" for k in range(3)) + " m"


@dataclass(frozen=True)
class RoiCrop:
    """What a region of interest kept of each pass.

    Attributes
    ----------
    box_ned_m : tuple of 6 float
        ``(x_min, y_min, z_min, x_max, y_max, z_max)``, table-centred NED (m).
    sources : tuple of str
        The passes, in the order given.
    n_points : tuple of int
        Points of each pass before the box.
    n_excluded : tuple of int
        Of them, the points outside the box (left out of every fit).
    """

    box_ned_m: RoiBox
    sources: tuple[str, ...]
    n_points: tuple[int, ...]
    n_excluded: tuple[int, ...]

    @property
    def n_points_total(self) -> int:
        """Points of all passes before the box."""
        return sum(self.n_points)

    @property
    def n_excluded_total(self) -> int:
        """Points of all passes outside the box."""
        return sum(self.n_excluded)

    def summary_text(self) -> str:
        """One line: the box and how many points it left out."""
        return (
            f"region of interest ({ROI_OPTION}, table-centred NED): {roi_text(self.box_ned_m)}; "
            f"{self.n_excluded_total} of {counted(self.n_points_total, 'point')} outside it, "
            "excluded"
        )

    def as_document(self) -> dict[str, Any]:
        """JSON-ready form (the ``roi`` entry of ``kinsync latency sphere --json``)."""
        return {
            "box_ned_m": {"min": list(self.box_ned_m[:3]), "max": list(self.box_ned_m[3:])},
            "n_points": self.n_points_total,
            "n_points_excluded": self.n_excluded_total,
            "passes": [
                {"file": s, "n_points": n, "n_points_excluded": x}
                for s, n, x in zip(self.sources, self.n_points, self.n_excluded, strict=True)
            ],
        }


def crop_passes(
    passes: Sequence[SpherePass], box: Sequence[float], min_points: int
) -> tuple[tuple[SpherePass, ...], RoiCrop]:
    """Keep the points of each pass inside ``box``.

    Parameters
    ----------
    passes : sequence of SpherePass
        Passes, table-centred NED.
    box : sequence of 6 float
        ``(x_min, y_min, z_min, x_max, y_max, z_max)``, table-centred NED (m); bounds
        included.
    min_points : int
        Fewest points a pass must keep (unless it had fewer to begin with).

    Returns
    -------
    passes : tuple of SpherePass
        The passes with the points inside the box (times kept alongside).
    crop : RoiCrop
        Points before the box and outside it, per pass.

    Raises
    ------
    InputError
        A bad box (`checked_roi`), or a box that leaves a pass of at least
        ``min_points`` points with fewer (the passes are named).
    """
    roi = checked_roi(box)
    lo, hi = np.array(roi[:3]), np.array(roi[3:])
    kept: list[SpherePass] = []
    excluded: list[int] = []
    short: list[str] = []
    for p in passes:
        inside = np.all((p.points_ned_m >= lo) & (p.points_ned_m <= hi), axis=1)
        n_in = int(inside.sum())
        if n_in < min_points <= p.n_points:
            short.append(f"{p.source} keeps {n_in} of its {counted(p.n_points, 'point')}")
        t_s = None if p.t_s is None else p.t_s[inside]
        kept.append(replace(p, points_ned_m=p.points_ned_m[inside], t_s=t_s))
        excluded.append(p.n_points - n_in)
    if short:
        more = f" (and {len(short) - _SHOWN} more passes)" if len(short) > _SHOWN else ""
        everything = np.concatenate([p.points_ned_m for p in passes])
        span = (*everything.min(axis=0), *everything.max(axis=0))
        msg = (
            f"region of interest ({_ROI_NAMES} {roi_text(roi)}, table-centred NED): "
            + "; ".join(short[:_SHOWN])
            + more
            + f"; a pass needs at least {min_points} points inside: move or widen the box so that "
            f"it holds the sphere in every pass (the passes' points span {roi_text(span)})"
        )
        raise InputError(msg)
    crop = RoiCrop(
        box_ned_m=roi,
        sources=tuple(p.source for p in passes),
        n_points=tuple(p.n_points for p in passes),
        n_excluded=tuple(excluded),
    )
    return tuple(kept), crop
