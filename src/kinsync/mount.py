"""System calibration of a scanner on a vehicle: the `Mount` container and its TOML form.

The TOML schema (exactly these keys)::

    [mount]
    lever_arm_body_m = [0.0, 0.0, 0.0]
    boresight_rpy_deg = [0.0, 0.0, 0.0]
    antenna_lever_arm_body_m = [0.0, 0.0, 0.0]
    latency_s = 0.0

    [profiler]          # optional: 2D profile scanners only
    azimuth_deg = 0.0   # fixed rotation about the scanner Z axis of the profile plane
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix

__all__ = ["Mount", "mount_from_toml_text", "mount_to_toml_text"]

Vector3 = tuple[float, float, float]

_KEYS = ("lever_arm_body_m", "boresight_rpy_deg", "antenna_lever_arm_body_m", "latency_s")


def _vector3(value: object, name: str, where: str) -> Vector3:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence | np.ndarray):
        msg = f"{where}{name}: expected a list of 3 numbers, got {value!r}"
        raise InputError(msg)
    items = list(value)
    if len(items) != 3 or not all(
        isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool)
        for v in items
    ):
        msg = f"{where}{name}: expected a list of 3 numbers, got {value!r}"
        raise InputError(msg)
    out = (float(items[0]), float(items[1]), float(items[2]))
    if not all(math.isfinite(v) for v in out):
        msg = f"{where}{name}: values must be finite, got {list(out)}"
        raise InputError(msg)
    return out


@dataclass(frozen=True)
class Mount:
    """Scanner mount on the vehicle body (the "system calibration").

    Attributes
    ----------
    lever_arm_body_m : tuple of 3 float
        Scanner origin relative to the IMU/body reference point, body frame FRD (m).
    boresight_rpy_deg : tuple of 3 float
        Boresight rotation scanner -> body as DIN 9300 roll, pitch, yaw (deg).
    antenna_lever_arm_body_m : tuple of 3 float
        GNSS antenna phase centre relative to the body reference point, FRD (m).
    latency_s : float
        Total latency tau (s); tau > 0 means the navigation record lags the scanner
        (SPEC section 1).
    profiler_azimuth_deg : float or None
        For a 2D profile scanner, the fixed azimuth (deg) about the scanner Z axis that
        puts the profile plane into the scanner frame (SPEC section 4): a profile point
        at mirror angle phi and range r is ``Rz(azimuth) (0, r sin phi, r cos phi)``.
        None when the scanner is not a profiler (no ``[profiler]`` table).
    """

    lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    boresight_rpy_deg: Vector3 = (0.0, 0.0, 0.0)
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    latency_s: float = 0.0
    profiler_azimuth_deg: float | None = None

    def __post_init__(self) -> None:
        for name in _KEYS[:3]:
            object.__setattr__(self, name, _vector3(getattr(self, name), name, "mount "))
        lat = self.latency_s
        if isinstance(lat, bool) or not isinstance(lat, (int, float, np.floating, np.integer)):
            msg = f"mount latency_s: expected a number of seconds, got {lat!r}"
            raise InputError(msg)
        if not math.isfinite(float(lat)):
            msg = f"mount latency_s: must be finite, got {lat!r}"
            raise InputError(msg)
        object.__setattr__(self, "latency_s", float(lat))
        az = self.profiler_azimuth_deg
        if az is not None:
            if isinstance(az, bool) or not isinstance(az, (int, float, np.floating, np.integer)):
                msg = f"mount [profiler] azimuth_deg: expected a number of degrees, got {az!r}"
                raise InputError(msg)
            if not math.isfinite(float(az)):
                msg = f"mount [profiler] azimuth_deg: must be finite, got {az!r}"
                raise InputError(msg)
            object.__setattr__(self, "profiler_azimuth_deg", float(az))

    @cached_property
    def R_scanner_to_body(self) -> FloatArray:
        """Boresight rotation matrix scanner -> body, shape (3, 3), read-only."""
        r, p, y = np.radians(self.boresight_rpy_deg)
        out = euler_rpy_to_matrix(r, p, y)
        out.setflags(write=False)
        return out

    @property
    def lever_arm_body_m_array(self) -> FloatArray:
        """Scanner lever arm as an array, shape (3,), body frame (m)."""
        return np.array(self.lever_arm_body_m)

    def with_latency(self, latency_s: float) -> Mount:
        """Return a copy with another latency (s)."""
        return replace(self, latency_s=latency_s)

    def profile_to_scanner(self, angle_rad: FloatArray, range_m: FloatArray) -> FloatArray:
        """2D profile points (mirror angle, range) in the scanner frame (SPEC section 4).

        Parameters
        ----------
        angle_rad : ndarray, shape (n,)
            Mirror angle phi from nadir, positive towards +Y (rad).
        range_m : ndarray, shape (n,)
            Range (m).

        Returns
        -------
        ndarray, shape (n, 3)
            ``Rz(azimuth) (0, r sin phi, r cos phi)``, scanner frame (m); azimuth 0 when
            the mount has no ``[profiler]`` table.
        """
        phi = np.asarray(angle_rad, dtype=np.float64)
        r = np.asarray(range_m, dtype=np.float64)
        az = math.radians(self.profiler_azimuth_deg or 0.0)
        y = r * np.sin(phi)
        z = r * np.cos(phi)
        return np.column_stack([-math.sin(az) * y, math.cos(az) * y, z])


def mount_from_toml_text(text: str, source: str = "<string>") -> Mount:
    """Parse a mount TOML document.

    Parameters
    ----------
    text : str
        TOML with a ``[mount]`` table holding the schema's keys (missing keys take
        their zero default; unknown keys are rejected so a typo cannot pass unnoticed).
    source : str
        Name used in error messages (usually the file path).

    Raises
    ------
    InputError
        Malformed TOML (with line and column), a missing ``[mount]`` table, unknown
        keys, or values of the wrong type or length.
    """
    try:
        doc: dict[str, Any] = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        msg = f"{source}: malformed TOML: {err}"
        raise InputError(msg) from err
    table = doc.get("mount")
    if not isinstance(table, Mapping):
        msg = f"{source}: no [mount] table; expected keys {', '.join(_KEYS)}"
        raise InputError(msg)
    unknown_tables = sorted(set(doc) - {"mount", "profiler"})
    if unknown_tables:
        msg = f"{source}: unknown table(s) {unknown_tables}; only [mount] and [profiler] are read"
        raise InputError(msg)
    unknown = sorted(set(table) - set(_KEYS))
    if unknown:
        msg = f"{source}: unknown key(s) in [mount]: {unknown}; expected {', '.join(_KEYS)}"
        raise InputError(msg)
    where = f"{source}: [mount] "
    kwargs: dict[str, Any] = {
        name: _vector3(table[name], name, where) for name in _KEYS[:3] if name in table
    }
    if "latency_s" in table:
        lat = table["latency_s"]
        if isinstance(lat, bool) or not isinstance(lat, (int, float)):
            msg = f"{where}latency_s: expected a number of seconds, got {lat!r}"
            raise InputError(msg)
        kwargs["latency_s"] = float(lat)
    if "profiler" in doc:
        prof = doc["profiler"]
        if not isinstance(prof, Mapping):
            msg = f"{source}: [profiler] must be a table with azimuth_deg"
            raise InputError(msg)
        unknown_p = sorted(set(prof) - {"azimuth_deg"})
        if unknown_p:
            msg = f"{source}: unknown key(s) in [profiler]: {unknown_p}; expected azimuth_deg"
            raise InputError(msg)
        kwargs["profiler_azimuth_deg"] = prof.get("azimuth_deg", 0.0)
    try:
        return Mount(**kwargs)
    except InputError as err:
        msg = f"{source}: {err}"
        raise InputError(msg) from err


def mount_to_toml_text(mount: Mount) -> str:
    """Serialise a mount to TOML in exactly the schema's layout.

    Floats are written with ``repr``, the shortest text that reads back to the same
    float64, so a save/load round trip is exact.
    """

    def vec(v: Vector3) -> str:
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    return (
        "[mount]\n"
        f"lever_arm_body_m = {vec(mount.lever_arm_body_m)}\n"
        f"boresight_rpy_deg = {vec(mount.boresight_rpy_deg)}\n"
        f"antenna_lever_arm_body_m = {vec(mount.antenna_lever_arm_body_m)}\n"
        f"latency_s = {float(mount.latency_s)!r}\n"
    ) + (
        ""
        if mount.profiler_azimuth_deg is None
        else f"\n[profiler]\nazimuth_deg = {float(mount.profiler_azimuth_deg)!r}\n"
    )
