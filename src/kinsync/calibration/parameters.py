"""The mount parameters a calibration can estimate: names, groups, units, the mount.

Seven parameters, in this order: the boresight angles scanner -> body (roll, pitch,
yaw in the DIN 9300 sequence of `kinsync.mount.Mount`), the scanner lever arm in the
body frame (x forward, y right, z down) and the latency tau (SPEC section 1: a point
measured at ``t`` is georeferenced with the navigation state tagged ``t + tau``).
Internally they are in radians, metres and seconds; reports use degrees, metres and
milliseconds, as their names say. Groups name the subsets a user asks for
(``--estimate boresight,latency``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Final

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.mount import MOUNT_PARAMETER_NAMES, Mount
from kinsync.mount_slips import derived_mounts

__all__ = [
    "BORESIGHT",
    "DEFAULT_ESTIMATE",
    "GROUPS",
    "LATENCY",
    "LEVER",
    "PARAMETER_NAMES",
    "REPORT_SCALE",
    "estimated_indices",
    "gimbal_lock_warning",
    "mount_from_values",
    "mount_values",
    "report_values",
]

PARAMETER_NAMES: Final = MOUNT_PARAMETER_NAMES
"""Names of the seven parameters, in the report's units (degrees, metres, milliseconds)."""

BORESIGHT: Final = (0, 1, 2)
LEVER: Final = (3, 4, 5)
LATENCY: Final = 6

GROUPS: Final[dict[str, tuple[int, ...]]] = {
    "boresight": BORESIGHT,
    "lever": LEVER,
    "lever_xy": (3, 4),
    "lever_z": (5,),
    "latency": (LATENCY,),
}
"""What ``--estimate`` names: groups of parameter indices."""

DEFAULT_ESTIMATE: Final = ("boresight", "latency")

REPORT_SCALE: Final = np.array([math.degrees(1.0)] * 3 + [1.0] * 3 + [1e3], dtype=np.float64)
"""Internal unit (rad, m, s) to the report's (deg, m, ms), per parameter."""


def estimated_indices(groups: str | tuple[str, ...] | list[str]) -> tuple[int, ...]:
    """Parameter indices of ``groups`` (``"boresight,latency"`` or a sequence), sorted.

    Raises
    ------
    InputError
        An unknown group or none at all.
    """
    names = [g.strip() for g in groups.split(",")] if isinstance(groups, str) else list(groups)
    names = [n for n in names if n]
    if not names:
        msg = f"estimate (--estimate): name at least one of {', '.join(GROUPS)}"
        raise InputError(msg)
    out: set[int] = set()
    for name in names:
        if name not in GROUPS:
            msg = f"estimate (--estimate): unknown group {name!r}; use {', '.join(GROUPS)}"
            raise InputError(msg)
        out.update(GROUPS[name])
    return tuple(sorted(out))


def mount_values(mount: Mount) -> FloatArray:
    """The seven parameters of ``mount`` in internal units (rad, m, s), shape (7,)."""
    return np.array(
        [
            *np.radians(mount.boresight_rpy_deg),
            *mount.lever_arm_body_m,
            mount.latency_s,
        ],
        dtype=np.float64,
    )


def report_values(mount: Mount) -> FloatArray:
    """The seven parameters of ``mount`` in report units (deg, m, ms), shape (7,).

    The angles as the mount gives them: through radians, -30 deg would come back as
    -29.999999999999996.
    """
    return np.array(
        [*mount.boresight_rpy_deg, *mount.lever_arm_body_m, mount.latency_s * 1e3],
        dtype=np.float64,
    )


def mount_from_values(base: Mount, values: FloatArray) -> Mount:
    """``base`` with the seven parameters ``values`` (internal units), shape (7,).

    Everything else of ``base`` (antenna lever arm, profiler azimuth) is kept, and so is
    each boresight angle whose value is ``base``'s own (held), exactly as written. A
    latency beyond 1 s gives no warning here: ``base`` was warned of (`derived_mounts`).
    """
    v = np.asarray(values, dtype=np.float64)
    given = np.radians(base.boresight_rpy_deg)
    rpy = np.where(v[:3] == given, base.boresight_rpy_deg, np.degrees(v[:3]))
    with derived_mounts():
        return replace(
            base,
            boresight_rpy_deg=(float(rpy[0]), float(rpy[1]), float(rpy[2])),
            lever_arm_body_m=(float(v[3]), float(v[4]), float(v[5])),
            latency_s=float(v[6]),
        )


GIMBAL_PITCH_DEG = 80.0
"""Beyond this |boresight pitch| roll and yaw are nearly one rotation (gimbal lock)."""


def gimbal_lock_warning(pitch_deg: float) -> str | None:
    """A warning when the boresight pitch lies within 10 deg of +-90 deg, else None.

    The boresight is estimated as roll, pitch and yaw: near a pitch of +-90 deg roll and
    yaw turn the scanner about nearly one axis, so their σ grow without bound and their
    statuses degrade while the data fix the scanner's orientation as well as anywhere.

    Near is judged by ``|sin(pitch)|``, which an equivalent triple (roll + 180, 180 -
    pitch, yaw + 180) shares: ``(180, -150, 210)`` is ``(0, -30, 30)``, 60 deg from it.

    Parameters
    ----------
    pitch_deg : float
        Boresight pitch (deg), the calibrated one (or the nominal one).
    """
    if abs(math.sin(math.radians(pitch_deg))) <= math.sin(math.radians(GIMBAL_PITCH_DEG)):
        return None
    return (
        f"the boresight pitch is {pitch_deg:.2f} deg: near +-90 deg roll and yaw are nearly "
        "the same rotation (gimbal lock): their σ grow and their statuses degrade although "
        "the data may fix the scanner's orientation as well as anywhere (a σ of degrees for "
        "a boresight known to hundredths); judge it by the overlaps after calibration"
    )
