"""System calibration of a scanner on a vehicle: the `Mount` container and its TOML form.

The TOML schema (exactly these keys)::

    [mount]
    lever_arm_body_m = [0.0, 0.0, 0.0]
    boresight_rpy_deg = [0.0, 0.0, 0.0]
    antenna_lever_arm_body_m = [0.0, 0.0, 0.0]
    latency_s = 0.0

    [profiler]          # optional: 2D profile scanners only
    azimuth_deg = 0.0   # fixed rotation about the scanner Z axis of the profile plane

    [uncertainty]       # optional, every key too: 1-sigma of the [mount] values
    lever_arm_body_m = [0.01, 0.01, 0.02]   # m, as surveyed (tape, total station)
    boresight_rpy_deg = [0.05, 0.05, 0.1]   # deg
    latency_s = 0.0005                      # s (e.g. from `kinsync latency sphere`)

    [uncertainty.correlation]   # optional: correlation coefficients of those errors
    names = ["lever_x_m", "latency_ms"]        # of MOUNT_PARAMETER_NAMES, each with a sigma
    matrix = [[1.0, -0.8], [-0.8, 1.0]]        # symmetric, unit diagonal, positive semidefinite

``latency_s`` is required: the latency is what kinsync measures, and a file without it
must not silently mean zero (write ``latency_s = 0.0`` when zero is meant). A missing
lever arm or boresight means zero. Values a mount cannot have are refused on reading:
a latency beyond +-`MAX_LATENCY_S`, a lever arm component beyond +-`MAX_LEVER_ARM_M`,
an angle beyond +-`MAX_ANGLE_DEG`: the `Mount` container refuses these itself (one
check for a file and a mount built in Python); the reader adds warnings for values few
mounts have (`kinsync.mount_slips`): a latency beyond 1 s warns when a `Mount` is built in
Python too.

``[uncertainty]`` says how well the values are known: what a calibration that holds a
parameter (not estimated, or not determined by the data) adds to the sigma of those it
estimates (`kinsync.calibration.held`), and what `kinsync calibrate mount` writes for
the parameters it calibrated. A key left out is not known; a standard deviation is
finite and not negative, and no larger than the value's own bound. The correlation
table says how the errors go together: a calibration's estimates are correlated (a
latency and a lever arm x told apart by the same speed changes), and a later
calibration that holds several of them adds ``D Sigma D'`` with the full ``Sigma``.
Values it does not name are uncorrelated with the others.

`toml_document` is the one TOML parser of kinsync's readers (mounts, INS
configurations): it accepts a UTF-8 byte-order mark and names the line and column of a
syntax error.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._text import shown_value
from kinsync._toml import toml_document
from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import profile_arrays
from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import euler_rpy_to_matrix
from kinsync.mount_slips import (
    STD_UNITS,
    WARN_LATENCY_S,
    WARN_LEVER_ARM_M,
    WARN_STD,
    derived_mounts,
    warn_latency_slip,
    warn_unit_slips,
)

__all__ = [
    "MAX_ANGLE_DEG",
    "MAX_LATENCY_S",
    "MAX_LEVER_ARM_M",
    "MAX_PROFILE_ANGLE_RAD",
    "MOUNT_PARAMETER_NAMES",
    "WARN_LATENCY_S",  # kinsync.mount_slips's, where they moved
    "WARN_LEVER_ARM_M",
    "WARN_STD",
    "Mount",
    "MountUncertainty",
    "StdCorrelation",
    "mount_from_toml_text",
    "mount_to_toml_text",
    "nearest_correlation",
    "toml_document",
]

Vector3 = tuple[float, float, float]

_KEYS = ("lever_arm_body_m", "boresight_rpy_deg", "antenna_lever_arm_body_m", "latency_s")
_UNCERTAINTY_KEYS = ("lever_arm_body_m", "boresight_rpy_deg", "latency_s")
_CORRELATION_KEYS = ("names", "matrix")

MOUNT_PARAMETER_NAMES = (
    "boresight_roll_deg",
    "boresight_pitch_deg",
    "boresight_yaw_deg",
    "lever_x_m",
    "lever_y_m",
    "lever_z_m",
    "latency_ms",
)
"""The seven calibrated values by name, in this order (the names a calibration reports
and ``[uncertainty.correlation]`` uses)."""
_NAME_KEY = dict(
    zip(
        MOUNT_PARAMETER_NAMES,
        ("boresight_rpy_deg",) * 3 + ("lever_arm_body_m",) * 3 + ("latency_s",),
        strict=True,
    )
)
_CORRELATION_TOLERANCE = 1e-6
"""Asymmetry, distance of the diagonal from 1 and excess beyond [-1, 1] a correlation
matrix may have (rounding of written values)."""

MAX_LATENCY_S = 10.0
"""Largest latency (s, either sign) a mount file may give. Latencies are milliseconds
(sensor delay, serial transmission, buffering: SPEC section 2); seconds are a time-scale
or unit mistake (UTC for GPS time, ms written as s) that georeferencing must not hide,
and 1e308 would wipe out every trajectory time."""

MAX_LEVER_ARM_M = 1000.0
"""Largest lever arm component (m, either sign): beyond any vehicle or vessel."""

MAX_ANGLE_DEG = 360.0
"""Largest boresight or profiler angle (deg, either sign): one turn."""

MAX_PROFILE_ANGLE_RAD = 2.0 * math.pi
"""Largest mirror angle of a profile return (rad, either sign): one turn, so that both
-pi..pi and 0..2 pi conventions read; more is degrees given as radians, or garbage, and
would move a return's clock time by whole profiles (``t = t0 + (n + phi / 2 pi) T``)."""


def _as_float(value: float | np.floating[Any] | np.integer[Any], label: str) -> float:
    """``float(value)``; an integer too large for a float64 is an `InputError`."""
    try:
        return float(value)
    except OverflowError as err:
        msg = f"{label}: a {len(str(value))}-digit integer is too large (floats end near 1.8e308)"
        raise InputError(msg) from err


def _vector3(value: object, name: str, where: str) -> Vector3:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence | np.ndarray):
        msg = f"{where}{name}: expected a list of 3 numbers, got {shown_value(value)}"
        raise InputError(msg)
    items = list(value)
    if len(items) != 3 or not all(
        isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool)
        for v in items
    ):
        msg = f"{where}{name}: expected a list of 3 numbers, got {len(items)}: {shown_value(value)}"
        raise InputError(msg)
    x, y, z = (_as_float(v, f"{where}{name}") for v in items)
    out = (x, y, z)
    if not all(math.isfinite(v) for v in out):
        msg = f"{where}{name}: values must be finite, got {list(out)}"
        raise InputError(msg)
    return out


def _std_value(value: object, label: str, limit: float, unit: str) -> float:
    """A standard deviation: a finite number in [0, limit] (``unit``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        msg = f"{label}: expected a standard deviation (a number), got {shown_value(value)}"
        raise InputError(msg)
    out = float(value)
    if not (math.isfinite(out) and 0.0 <= out <= limit):
        msg = (
            f"{label} = {value!r}: a standard deviation must be finite, not negative and "
            f"at most {limit:g} {unit}"
        )
        raise InputError(msg)
    return out


def nearest_correlation(r: FloatArray) -> FloatArray:
    """The positive semidefinite correlation matrix nearest ``r`` (n, n), shape (n, n).

    ``r`` symmetrised; when an eigenvalue is below -1e-12 (rounding, or a matrix read
    within `_CORRELATION_TOLERANCE`), negative eigenvalues set to 0 and the diagonal
    scaled back to 1. Unchanged otherwise, so a written matrix reads back exactly.
    Propagated through a calibration (``[D; I] Sigma [D; I]'``) a negative eigenvalue
    grows, and the written table would be refused.

    Parameters
    ----------
    r : ndarray, shape (n, n)
        A correlation matrix (dimensionless): unit diagonal, coefficients in [-1, 1],
        symmetric to rounding. Not checked here (`StdCorrelation` checks it first).

    Returns
    -------
    ndarray of float64, shape (n, n)
        A copy of ``r`` when its smallest eigenvalue is at least -1e-12; otherwise the
        repaired matrix: symmetric, unit diagonal, positive semidefinite.
    """
    sym = 0.5 * (r + r.T)
    w, v = np.linalg.eigh(sym)
    if w[0] >= -1e-12:
        out: FloatArray = np.array(r, dtype=np.float64)
        return out
    fixed = (v * np.maximum(w, 0.0)) @ v.T
    d = np.sqrt(np.diag(fixed))
    fixed = np.clip(fixed / np.outer(d, d), -1.0, 1.0)
    result: FloatArray = 0.5 * (fixed + fixed.T)
    np.fill_diagonal(result, 1.0)
    return result


_TABLE_KEY_HINT = {
    "latency_s": "the latency is latency_ms here (a name, not the [uncertainty] key)",
    "lever_arm_body_m": "name the components: lever_x_m, lever_y_m, lever_z_m",
    "boresight_rpy_deg": "name the angles: boresight_roll_deg, boresight_pitch_deg, "
    "boresight_yaw_deg",
}
"""What to write instead of an ``[uncertainty]`` key given as a correlation name."""

PSD_ROUNDING = 0.05
"""Smallest eigenvalue a correlation matrix may have (read with a warning, then the
nearest positive semidefinite matrix used): what coefficients rounded to two decimals
give a 7 x 7 matrix of strong correlations (-0.002 for a calibration's). A more negative
one is no rounding: no errors can have it."""


def _entry(names: Sequence[str], i: int, j: int) -> str:
    return f"matrix[{i}][{j}] ({names[i]}/{names[j]})"


def _matrix_defect(r: FloatArray, names: Sequence[str]) -> str:
    """What is wrong with a correlation matrix ``r`` (n, n), naming the entry.

    "" if nothing: within `_CORRELATION_TOLERANCE`, eigenvalues down to -`PSD_ROUNDING`.
    """
    tol = _CORRELATION_TOLERANCE
    if not np.all(np.isfinite(r)):
        i, j = (int(k) for k in np.argwhere(~np.isfinite(r))[0])
        return f"{_entry(names, i, j)} = {r[i, j]!r}: not a finite number"
    dev = np.abs(np.diag(r) - 1.0)
    if np.max(dev) > tol:
        i = int(np.argmax(dev))
        return f"{_entry(names, i, i)} = {r[i, i]!r}: the diagonal is 1 (a value with itself)"
    asym = np.abs(r - r.T)
    if np.max(asym) > tol:
        a, b = (int(k) for k in np.unravel_index(int(np.argmax(asym)), asym.shape))
        return (
            f"{_entry(names, a, b)} = {r[a, b]!r} but matrix[{b}][{a}] = "
            f"{r[b, a]!r}: the matrix is symmetric"
        )
    if np.max(np.abs(r)) > 1.0 + tol:
        a, b = (int(k) for k in np.unravel_index(int(np.argmax(np.abs(r))), r.shape))
        return f"{_entry(names, a, b)} = {r[a, b]!r}: a coefficient is within [-1, 1]"
    low = float(np.min(np.linalg.eigvalsh(0.5 * (r + r.T))))
    if low < -PSD_ROUNDING:
        return (
            f"matrix: not positive semidefinite (smallest eigenvalue {low:.3g}): no errors "
            "can have these correlations; copy the table from the mount `calibrate mount "
            "--out` wrote"
        )
    return ""


@dataclass(frozen=True)
class StdCorrelation:
    """Correlation coefficients between the errors of some of a mount's values.

    Attributes
    ----------
    names : tuple of str
        Distinct names of `MOUNT_PARAMETER_NAMES`, at least two.
    matrix : tuple of tuple of float
        Their correlation matrix, (n, n): symmetric, unit diagonal, coefficients in
        [-1, 1] (each within `_CORRELATION_TOLERANCE`), and positive semidefinite:
        a matrix whose smallest eigenvalue is down to -`PSD_ROUNDING` (coefficients
        rounded by hand) is stored as the nearest positive semidefinite one
        (`nearest_correlation`); the reader warns.
    """

    names: tuple[str, ...]
    matrix: tuple[tuple[float, ...], ...]

    def __post_init__(self) -> None:
        where = "mount [uncertainty.correlation]"
        names = self.names
        if isinstance(names, str) or not isinstance(names, Sequence):
            msg = f"{where} names: expected a list of names, got {shown_value(names)}"
            raise InputError(msg)
        unknown = [n for n in names if n not in MOUNT_PARAMETER_NAMES]
        if unknown:
            hint = "".join(f"; {_TABLE_KEY_HINT[u]}" for u in unknown if u in _TABLE_KEY_HINT)
            msg = (
                f"{where} names: unknown name(s) {unknown}; expected some of "
                f"{', '.join(MOUNT_PARAMETER_NAMES)}{hint}"
            )
            raise InputError(msg)
        twice = sorted({x for x in names if list(names).count(x) > 1})
        if twice:
            msg = f"{where} names: {', '.join(twice)} named twice; name each value once"
            raise InputError(msg)
        if len(names) < 2:
            msg = f"{where} names: a correlation needs at least two values, got {list(names)}"
            raise InputError(msg)
        n = len(names)
        rows = self.matrix
        if (
            isinstance(rows, str)
            or not isinstance(rows, Sequence)
            or len(rows) != n
            or any(isinstance(r, str) or not isinstance(r, Sequence) or len(r) != n for r in rows)
        ):
            msg = f"{where} matrix: expected {n} rows of {n} numbers (one per name)"
            raise InputError(msg)
        for i, row in enumerate(rows):
            for j, v in enumerate(row):
                if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                    msg = f"{where} matrix[{i}][{j}]: expected a number, got {shown_value(v)}"
                    raise InputError(msg)
        r = np.array(rows, dtype=np.float64)
        bad = _matrix_defect(r, names)
        if bad:
            msg = f"{where} {bad}"
            raise InputError(msg)
        object.__setattr__(self, "names", tuple(str(x) for x in names))
        fixed = nearest_correlation(r)
        object.__setattr__(self, "matrix", tuple(tuple(float(v) for v in row) for row in fixed))

    def without(self, names: Sequence[str]) -> StdCorrelation | None:
        """The correlations of the other values (None when fewer than two remain).

        Parameters
        ----------
        names : sequence of str
            Names of `MOUNT_PARAMETER_NAMES` to leave out; a name this table does not
            hold is ignored.

        Returns
        -------
        StdCorrelation or None
            The rows and columns of the remaining names, in this table's order; None
            when fewer than two names remain (no correlation left to state).
        """
        keep = [i for i, n in enumerate(self.names) if n not in names]
        if len(keep) < 2:
            return None
        rows = tuple(tuple(self.matrix[i][j] for j in keep) for i in keep)
        return StdCorrelation(tuple(self.names[i] for i in keep), rows)

    def as_document(self) -> dict[str, Any]:
        """``{"names": [...], "matrix": [[...], ...]}``, as the calibration's ``--json``."""
        return {"names": list(self.names), "matrix": [list(r) for r in self.matrix]}


@dataclass(frozen=True)
class MountUncertainty:
    """Standard deviations (1 sigma) of a mount's values; None where not known.

    Attributes
    ----------
    lever_arm_body_m : tuple of 3 float or None
        Of the scanner lever arm, body frame FRD (m).
    boresight_rpy_deg : tuple of 3 float or None
        Of the boresight roll, pitch, yaw (deg).
    latency_s : float or None
        Of the latency (s).
    correlation : StdCorrelation or None
        How the errors of some of these values go together; None: independent. Every
        value it names has its standard deviation here.
    """

    lever_arm_body_m: Vector3 | None = None
    boresight_rpy_deg: Vector3 | None = None
    latency_s: float | None = None
    correlation: StdCorrelation | None = None

    def __post_init__(self) -> None:
        if self.correlation is not None:
            if not isinstance(self.correlation, StdCorrelation):
                got = self.correlation
                msg = f"mount [uncertainty] correlation: expected a StdCorrelation, got {got!r}"
                raise InputError(msg)
            missing = sorted(
                {_NAME_KEY[n] for n in self.correlation.names}
                - {k for k in _UNCERTAINTY_KEYS if getattr(self, k) is not None}
            )
            if missing:
                msg = (
                    f"mount [uncertainty.correlation] names values whose standard deviation "
                    f"[uncertainty] does not give ({', '.join(missing)}): give them, or leave "
                    "those values out of the correlation"
                )
                raise InputError(msg)
        limits = {"lever_arm_body_m": MAX_LEVER_ARM_M, "boresight_rpy_deg": MAX_ANGLE_DEG}
        for name, limit in limits.items():
            value = getattr(self, name)
            if value is None:
                continue
            vec = _vector3(value, name, "mount [uncertainty] ")
            checked = tuple(
                _std_value(v, f"mount [uncertainty] {name}[{i}]", limit, STD_UNITS[name])
                for i, v in enumerate(vec)
            )
            object.__setattr__(self, name, checked)
        if self.latency_s is not None:
            lat = _std_value(self.latency_s, "mount [uncertainty] latency_s", MAX_LATENCY_S, "s")
            object.__setattr__(self, "latency_s", lat)

    def with_independent(
        self,
        *,
        lever_arm_body_m: Vector3 | None = None,
        boresight_rpy_deg: Vector3 | None = None,
        latency_s: float | None = None,
    ) -> MountUncertainty:
        """These standard deviations replaced by new, independent ones.

        A value measured again on its own (the latency from a sphere) is no longer
        correlated with the others: the correlations that name it are dropped, the
        others' kept.

        Parameters
        ----------
        lever_arm_body_m : tuple of 3 float, optional
            New 1-sigma of the scanner lever arm, body frame FRD (m); default: keep
            this table's.
        boresight_rpy_deg : tuple of 3 float, optional
            New 1-sigma of the boresight roll, pitch, yaw (deg); default: keep this
            table's.
        latency_s : float, optional
            New 1-sigma of the latency (s); default: keep this table's.

        Returns
        -------
        MountUncertainty
            A new table; this one is unchanged. A value given replaces the old one and
            the correlation entries of its names (all three components of a vector) are
            dropped (`StdCorrelation.without`).

        Raises
        ------
        InputError
            A new value that is not a finite number (or 3 of them), is negative, or is
            beyond its bound (`MAX_LEVER_ARM_M`, `MAX_ANGLE_DEG`, `MAX_LATENCY_S`).
        """
        given = {
            "lever_arm_body_m": lever_arm_body_m,
            "boresight_rpy_deg": boresight_rpy_deg,
            "latency_s": latency_s,
        }
        names = [n for n, key in _NAME_KEY.items() if given[key] is not None]
        corr = None if self.correlation is None else self.correlation.without(names)
        kept: dict[str, Any] = {k: getattr(self, k) if v is None else v for k, v in given.items()}
        return MountUncertainty(**kept, correlation=corr)

    @property
    def known(self) -> bool:
        """True when at least one standard deviation is given."""
        return any(getattr(self, k) is not None for k in _UNCERTAINTY_KEYS)

    def as_document(self) -> dict[str, Any]:
        """The table as JSON.

        Each key's standard deviation(s), null where not known, and ``correlation``
        (`StdCorrelation.as_document`, null when the errors are independent).
        """
        return {
            "lever_arm_body_m": (
                None if self.lever_arm_body_m is None else list(self.lever_arm_body_m)
            ),
            "boresight_rpy_deg": (
                None if self.boresight_rpy_deg is None else list(self.boresight_rpy_deg)
            ),
            "latency_s": self.latency_s,
            "correlation": None if self.correlation is None else self.correlation.as_document(),
        }


@dataclass(frozen=True)
class Mount(ReadOnlyArrays):
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
    uncertainty : MountUncertainty or None
        How well the values are known (the ``[uncertainty]`` table); None when the file
        says nothing.

    Raises
    ------
    InputError
        A value that is not a finite number (or 3 of them), or one no mount has: a
        latency beyond +-`MAX_LATENCY_S`, a lever arm component beyond
        +-`MAX_LEVER_ARM_M`, a boresight or profiler angle beyond +-`MAX_ANGLE_DEG`.

    Warns
    -----
    KinsyncWarning
        A latency beyond +-`kinsync.mount_slips.WARN_LATENCY_S` (1 s), longer than any
        sensor or serial delay: 5 written for 5 ms (a mount file's reader gives it
        instead, naming the file).
    """

    lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    boresight_rpy_deg: Vector3 = (0.0, 0.0, 0.0)
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    latency_s: float = 0.0
    profiler_azimuth_deg: float | None = None
    uncertainty: MountUncertainty | None = None

    def __post_init__(self) -> None:
        if self.uncertainty is not None and not isinstance(self.uncertainty, MountUncertainty):
            msg = f"mount uncertainty: expected a MountUncertainty, got {self.uncertainty!r}"
            raise InputError(msg)
        for name in _KEYS[:3]:
            object.__setattr__(self, name, _vector3(getattr(self, name), name, "mount "))
        lat = self.latency_s
        if isinstance(lat, bool) or not isinstance(lat, (int, float, np.floating, np.integer)):
            msg = f"mount latency_s: expected a number of seconds, got {shown_value(lat)}"
            raise InputError(msg)
        lat_s = _as_float(lat, "mount latency_s")
        if not math.isfinite(lat_s):
            msg = f"mount latency_s: must be finite, got {lat!r}"
            raise InputError(msg)
        object.__setattr__(self, "latency_s", lat_s)
        az = self.profiler_azimuth_deg
        if az is not None:
            if isinstance(az, bool) or not isinstance(az, (int, float, np.floating, np.integer)):
                got = shown_value(az)
                msg = f"mount [profiler] azimuth_deg: expected a number of degrees, got {got}"
                raise InputError(msg)
            az_deg = _as_float(az, "mount [profiler] azimuth_deg")
            if not math.isfinite(az_deg):
                msg = f"mount [profiler] azimuth_deg: must be finite, got {az!r}"
                raise InputError(msg)
            object.__setattr__(self, "profiler_azimuth_deg", az_deg)
        _refuse_impossible(self)
        warn_latency_slip(self.latency_s, stacklevel=3)

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
        """Return a copy with another latency (s).

        Parameters
        ----------
        latency_s : float
            The new total latency tau (s), sign as `Mount.latency_s` (tau > 0: the
            navigation record lags the scanner). The other values and the uncertainty
            are kept.

        Returns
        -------
        Mount
            A new mount; this one is unchanged.

        Raises
        ------
        InputError
            ``latency_s`` not a finite number, or beyond +-`MAX_LATENCY_S`.
        """
        return replace(self, latency_s=latency_s)

    def with_profiler_azimuth(self, azimuth_deg: float) -> Mount:
        """Return a copy with another profiler azimuth (deg).

        Parameters
        ----------
        azimuth_deg : float
            The fixed azimuth (deg) of the profile plane about the scanner Z axis
            (`Mount.profiler_azimuth_deg`). The other values are kept, and the latency
            is not warned of again (it was when this mount was made).

        Returns
        -------
        Mount
            A new mount; this one is unchanged.

        Raises
        ------
        InputError
            ``azimuth_deg`` not a finite number, or beyond +-`MAX_ANGLE_DEG`.
        """
        with derived_mounts():
            return replace(self, profiler_azimuth_deg=azimuth_deg)

    def as_document(self) -> dict[str, Any]:
        """Its values as JSON, ``uncertainty`` as `MountUncertainty.as_document` (or null)."""
        u = self.uncertainty
        return {
            "lever_arm_body_m": list(self.lever_arm_body_m),
            "boresight_rpy_deg": list(self.boresight_rpy_deg),
            "antenna_lever_arm_body_m": list(self.antenna_lever_arm_body_m),
            "latency_s": self.latency_s,
            "profiler_azimuth_deg": self.profiler_azimuth_deg,
            "uncertainty": None if u is None else u.as_document(),
        }

    def profile_to_scanner(self, *, angle_rad: ArrayLike, range_m: ArrayLike) -> FloatArray:
        """2D profile points (mirror angle, range) in the scanner frame (SPEC section 4).

        Both arrays are keyword-only (``angle_rad=``, ``range_m=``): two float arrays
        in the wrong order would give wrong points without an error whenever every
        range is under 2 pi m.

        Parameters
        ----------
        angle_rad : array_like, shape (n,)
            Mirror angle phi from nadir, positive towards +Y (rad), within one turn.
        range_m : array_like, shape (n,)
            Range (m), >= 0.

        Returns
        -------
        ndarray, shape (n, 3)
            ``Rz(azimuth) (0, r sin phi, r cos phi)``, scanner frame (m); azimuth 0 when
            the mount has no ``[profiler]`` table.

        Raises
        ------
        InputError
            Not 1-D of one length, NaN, an angle beyond one turn, a range below 0.
        """
        phi, r = profile_arrays(angle_rad, range_m, MAX_PROFILE_ANGLE_RAD, "profile_to_scanner")
        az = math.radians(self.profiler_azimuth_deg or 0.0)
        y = r * np.sin(phi)
        z = r * np.cos(phi)
        return np.column_stack([-math.sin(az) * y, math.cos(az) * y, z])


def mount_from_toml_text(text: str, source: str = "<string>") -> Mount:
    """Parse a mount TOML document.

    Parameters
    ----------
    text : str
        TOML with a ``[mount]`` table holding the schema's keys: ``latency_s`` is
        required, a missing lever arm or boresight is zero; unknown keys are rejected
        so a typo cannot pass unnoticed. A UTF-8 byte-order mark is accepted.
    source : str
        Name used in error messages (usually the file path).

    Raises
    ------
    InputError
        Malformed TOML (with line and column), a missing ``[mount]`` table, unknown
        keys, values of the wrong type or length, a missing ``latency_s``, or values
        beyond `MAX_LATENCY_S`, `MAX_LEVER_ARM_M` or `MAX_ANGLE_DEG`.
    """
    doc = toml_document(text, source)
    table = doc.get("mount")
    if not isinstance(table, Mapping):
        msg = f"{source}: no [mount] table; expected keys {', '.join(_KEYS)}"
        raise InputError(msg)
    unknown_tables = sorted(set(doc) - {"mount", "profiler", "uncertainty"})
    if unknown_tables:
        msg = (
            f"{source}: unknown table(s) {shown_value(unknown_tables)}; only [mount], "
            "[profiler] and [uncertainty] (with [uncertainty.correlation]) are read"
            + (
                "; the correlations go in [uncertainty.correlation]"
                if "correlation" in unknown_tables
                else ""
            )
        )
        raise InputError(msg)
    unknown = sorted(set(table) - set(_KEYS))
    if unknown:
        got = shown_value(unknown)
        msg = f"{source}: unknown key(s) in [mount]: {got}; expected {', '.join(_KEYS)}"
        raise InputError(msg)
    where = f"{source}: [mount] "
    kwargs: dict[str, Any] = {
        name: _vector3(table[name], name, where) for name in _KEYS[:3] if name in table
    }
    if "latency_s" in table:
        lat = table["latency_s"]
        if isinstance(lat, bool) or not isinstance(lat, (int, float)):
            msg = f"{where}latency_s: expected a number of seconds, got {shown_value(lat)}"
            raise InputError(msg)
        kwargs["latency_s"] = _as_float(lat, f"{where}latency_s")
    if "profiler" in doc:
        prof = doc["profiler"]
        if not isinstance(prof, Mapping):
            msg = f"{source}: [profiler] must be a table with azimuth_deg"
            raise InputError(msg)
        unknown_p = sorted(set(prof) - {"azimuth_deg"})
        if unknown_p or "azimuth_deg" not in prof:  # an empty table is not azimuth 0
            got = f"unknown key(s) in [profiler]: {shown_value(unknown_p)}; expected"
            msg = f"{source}: {got if unknown_p else '[profiler] has no'} azimuth_deg"
            raise InputError(msg + " (deg about the scanner Z axis; 0.0 for an unturned plane)")
        kwargs["profiler_azimuth_deg"] = prof["azimuth_deg"]
    if "uncertainty" in doc:
        kwargs["uncertainty"] = _uncertainty_table(doc["uncertainty"], source)
    try:
        with derived_mounts():  # warned of below, naming the file
            mount = Mount(**kwargs)
    except InputError as err:
        msg = f"{source}: {err}"
        raise InputError(msg) from err
    if "latency_s" not in table:
        msg = (
            f"{where}latency_s is missing; write latency_s = 0.0 explicitly if the latency "
            "is zero (a missing latency is not taken to mean zero)"
        )
        raise InputError(msg)
    unc = mount.uncertainty
    warn_unit_slips(
        source,
        mount.latency_s,
        {name: getattr(mount, name) for name in ("lever_arm_body_m", "antenna_lever_arm_body_m")},
        {key: None if unc is None else getattr(unc, key) for key in WARN_STD},
    )
    return mount


def _uncertainty_table(table: object, source: str) -> MountUncertainty:
    """The ``[uncertainty]`` table: standard deviations of the ``[mount]`` values."""
    if not isinstance(table, Mapping):
        msg = f"{source}: [uncertainty] must be a table with {', '.join(_UNCERTAINTY_KEYS)}"
        raise InputError(msg)
    unknown = sorted(set(table) - {*_UNCERTAINTY_KEYS, "correlation"})
    if unknown:
        msg = (
            f"{source}: unknown key(s) in [uncertainty]: {shown_value(unknown)}; expected "
            f"{', '.join(_UNCERTAINTY_KEYS)} (standard deviations of the [mount] values, in "
            "their units) and the [uncertainty.correlation] table"
        )
        raise InputError(msg)
    values = {str(k): v for k, v in table.items() if k != "correlation"}
    try:
        if "correlation" in table:
            values["correlation"] = _correlation_table(table["correlation"], source)
        return MountUncertainty(**values)
    except InputError as err:
        msg = f"{source}: {err}"
        raise InputError(msg) from err


def _correlation_table(table: object, source: str) -> StdCorrelation:
    """The ``[uncertainty.correlation]`` table: ``names`` and ``matrix``.

    A matrix that is not quite positive semidefinite (rounded coefficients) is read with
    a warning naming its smallest eigenvalue; the nearest such matrix is used.
    """
    if not isinstance(table, Mapping) or set(table) != set(_CORRELATION_KEYS):
        keys = sorted(table) if isinstance(table, Mapping) else None
        renamed = "; parameters is now names" if keys and "parameters" in keys else ""
        msg = (
            "[uncertainty.correlation] must be a table with exactly names (of the values) and "
            f"matrix (their correlation coefficients), got {shown_value(keys or table)}{renamed}"
        )
        raise InputError(msg)
    names, rows = table["names"], table["matrix"]
    listed = not isinstance(names, str) and isinstance(names, Sequence)
    if not listed or not all(isinstance(n, str) for n in names):
        got = shown_value(names)
        msg = f"mount [uncertainty.correlation] names: expected a list of names (text), got {got}"
        raise InputError(msg)
    corr = StdCorrelation(tuple(names), rows)
    low = float(np.min(np.linalg.eigvalsh(np.array(rows, dtype=np.float64))))
    if low < -_CORRELATION_TOLERANCE:
        warnings.warn(
            f"{source}: [uncertainty.correlation] matrix is not quite positive semidefinite "
            f"(smallest eigenvalue {low:.2g}, as coefficients rounded by hand give): the "
            "nearest positive semidefinite matrix is used; copy the table from the mount "
            "`calibrate mount --out` wrote to keep it exact",
            KinsyncWarning,
            stacklevel=4,
        )
    return corr


def _refuse_impossible(mount: Mount) -> None:
    """Refuse values no mount has (`MAX_LATENCY_S`, `MAX_LEVER_ARM_M`, `MAX_ANGLE_DEG`).

    The container's own check (`Mount.__post_init__`), so a mount file and a mount built
    in Python are held to one rule; the reader prefixes the file's name.
    """
    if abs(mount.latency_s) > MAX_LATENCY_S:
        msg = (
            f"mount latency_s = {mount.latency_s!r} s is beyond +-{MAX_LATENCY_S:g} s; "
            "latencies are milliseconds: a larger value is a unit or time-scale mistake "
            "(give seconds, and put the trajectory and the points on one time scale)"
        )
        raise InputError(msg)
    limits = (
        ("lever_arm_body_m", MAX_LEVER_ARM_M, "m", "no vehicle is that large: metres expected"),
        ("antenna_lever_arm_body_m", MAX_LEVER_ARM_M, "m", "no vehicle is that large"),
        ("boresight_rpy_deg", MAX_ANGLE_DEG, "deg", "give angles in degrees within one turn"),
    )
    for name, limit, unit, hint in limits:
        values: Vector3 = getattr(mount, name)
        for i, value in enumerate(values):
            if abs(value) > limit:
                msg = f"mount {name}[{i}] = {value!r} {unit} is beyond +-{limit:g} {unit} ({hint})"
                raise InputError(msg)
    az = mount.profiler_azimuth_deg
    if az is not None and abs(az) > MAX_ANGLE_DEG:
        msg = (
            f"mount [profiler] azimuth_deg = {az!r} deg is beyond +-{MAX_ANGLE_DEG:g} deg "
            "(give degrees within one turn)"
        )
        raise InputError(msg)


def mount_to_toml_text(mount: Mount) -> str:
    """Serialise a mount to TOML in exactly the schema's layout.

    Floats are written with ``repr``, the shortest text that reads back to the same
    float64, so a save/load round trip is exact.

    Parameters
    ----------
    mount : Mount
        The mount to write: ``[mount]`` always, ``[profiler]`` when it has a profiler
        azimuth, ``[uncertainty]`` (and ``[uncertainty.correlation]``) when it gives at
        least one standard deviation. Units as the schema: m, deg, s.

    Returns
    -------
    str
        The TOML document, ending in a newline, that `mount_from_toml_text` reads
        back.
    """

    def vec(v: Vector3) -> str:
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    text = (
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
    unc = mount.uncertainty
    if unc is None or not unc.known:
        return text
    text += "\n[uncertainty]  # 1-sigma of the [mount] values, same units\n"
    if unc.lever_arm_body_m is not None:
        text += f"lever_arm_body_m = {vec(unc.lever_arm_body_m)}\n"
    if unc.boresight_rpy_deg is not None:
        text += f"boresight_rpy_deg = {vec(unc.boresight_rpy_deg)}\n"
    if unc.latency_s is not None:
        text += f"latency_s = {float(unc.latency_s)!r}\n"
    corr = unc.correlation
    if corr is not None:
        names = ", ".join(f'"{n}"' for n in corr.names)
        rows = ",\n".join("    [" + ", ".join(repr(v) for v in row) + "]" for row in corr.matrix)
        text += (
            "\n[uncertainty.correlation]  # correlation coefficients of those errors\n"
            f"names = [{names}]\nmatrix = [\n{rows},\n]\n"
        )
    return text
