"""The mount a profile clock was fitted with, recorded in the clock file.

Method B finds the profile clock from where the mount puts the scan plane, so the clock
holds the mount: 1 ms of ``latency_s`` moves t0 by 1 ms, a lever arm or boresight off
moves t0 and the period (`kinsync.sync.mount_effect`). Points time-tagged with the clock
and georeferenced with another mount count the difference twice. ``kinsync sync
object-space --json`` records the values (`ClockMount.as_document`) and ``kinsync sync
apply --clock`` refuses a ``--mount`` whose values differ (`ClockMount.differences`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from kinsync.mount import Mount, Vector3

__all__ = ["CLOCK_MOUNT_TOLERANCE", "ClockMount"]

CLOCK_MOUNT_TOLERANCE = 1e-9
"""Values closer than this (s, m or deg) are the same: far below any effect on a clock."""


@dataclass(frozen=True)
class ClockMount:
    """The mount values a profile clock was fitted with, and the file they came from.

    Attributes
    ----------
    source : str
        The mount file as it was given to ``sync object-space``.
    latency_s : float
        The mount's latency (s).
    lever_arm_body_m : tuple of 3 float
        Scanner lever arm, body frame FRD (m).
    boresight_rpy_deg : tuple of 3 float
        Boresight scanner -> body, roll, pitch, yaw (deg).
    profiler_azimuth_deg : float or None
        The ``[profiler] azimuth_deg`` (deg), None when the mount has none.
    """

    source: str
    latency_s: float
    lever_arm_body_m: Vector3
    boresight_rpy_deg: Vector3
    profiler_azimuth_deg: float | None

    @classmethod
    def of(cls, mount: Mount, source: str) -> ClockMount:
        """The values of ``mount`` that move the clock, read from ``source``."""
        return cls(
            source=source,
            latency_s=mount.latency_s,
            lever_arm_body_m=mount.lever_arm_body_m,
            boresight_rpy_deg=mount.boresight_rpy_deg,
            profiler_azimuth_deg=mount.profiler_azimuth_deg,
        )

    def as_document(self) -> dict[str, Any]:
        """JSON-ready dict: ``path`` and the values, as in the mount file."""
        return {
            "path": self.source,
            "latency_s": self.latency_s,
            "lever_arm_body_m": list(self.lever_arm_body_m),
            "boresight_rpy_deg": list(self.boresight_rpy_deg),
            "profiler_azimuth_deg": self.profiler_azimuth_deg,
        }

    def differences(self, mount: Mount) -> list[str]:
        """The values where ``mount`` differs from this one, as text (empty when none).

        Each entry reads ``latency_s 0.0 (the clock's) vs 0.005``; values within
        `CLOCK_MOUNT_TOLERANCE` are the same.
        """
        out: list[str] = []
        pairs: tuple[tuple[str, Any, Any], ...] = (
            ("latency_s", self.latency_s, mount.latency_s),
            ("lever_arm_body_m", self.lever_arm_body_m, mount.lever_arm_body_m),
            ("boresight_rpy_deg", self.boresight_rpy_deg, mount.boresight_rpy_deg),
            ("[profiler] azimuth_deg", self.profiler_azimuth_deg, mount.profiler_azimuth_deg),
        )
        for name, mine, theirs in pairs:
            if not _same(mine, theirs):
                out.append(f"{name} {_shown(mine)} (the clock's) vs {_shown(theirs)}")
        return out


def _same(a: float | Vector3 | None, b: float | Vector3 | None) -> bool:
    """Whether two values (numbers, triples or None) agree within the tolerance."""
    if a is None or b is None:
        return a is None and b is None
    xs = a if isinstance(a, tuple) else (a,)
    ys = b if isinstance(b, tuple) else (b,)
    return len(xs) == len(ys) and all(
        math.isclose(x, y, rel_tol=0.0, abs_tol=CLOCK_MOUNT_TOLERANCE)
        for x, y in zip(xs, ys, strict=True)
    )


def _shown(value: float | Vector3 | None) -> str:
    """A value as the mount file writes it: ``0.005``, ``[0.6, 0.0, -1.4]``, ``none``."""
    if value is None:
        return "none"
    if isinstance(value, tuple):
        return "[" + ", ".join(repr(float(v)) for v in value) + "]"
    return repr(float(value))
