"""What a mount calibration reports: every parameter with its sigma and status."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import FloatArray
from kinsync.calibration.held import HeldEffect
from kinsync.calibration.overlaps import LineOverlap
from kinsync.mount import Mount

__all__ = ["CalibrationResult", "FeatureSummary", "ParameterEstimate", "Status"]

Status = Literal["estimated", "weak", "unobservable", "fixed"]
"""``estimated``: determined, with an honest sigma below the threshold; ``weak``:
determined, but its sigma is above the threshold or not known to be below it (the
formal sigma, or a jackknife over too few lines: `kinsync.calibration.estimator`);
``unobservable``: the data cannot determine it (held at its prior value); ``fixed``:
not asked for (held)."""


def _num(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


@dataclass(frozen=True)
class ParameterEstimate:
    """One mount parameter after the calibration (report units: deg, m, ms).

    Attributes
    ----------
    name : str
        ``boresight_roll_deg`` .. ``latency_ms``.
    value : float
        Calibrated value (the prior for ``unobservable`` and ``fixed``).
    prior : float
        The starting value (the mount given).
    std : float
        Standard deviation (NaN for ``unobservable`` and ``fixed``): ``data_std`` and
        ``held_std`` together (``sqrt(data_std^2 + held_std^2)``).
    formal_std : float
        Formal standard deviation from the Jacobian (NaN when not estimated).
    status : {"estimated", "weak", "unobservable", "fixed"}
    data_std : float
        What the data leave: the jackknife over lines, or the formal sigma (NaN when
        not estimated).
    held_std : float
        What the held parameters' stated uncertainty adds (`kinsync.calibration.held`;
        0 when none is stated, NaN when not estimated).
    """

    name: str
    value: float
    prior: float
    std: float
    formal_std: float
    status: Status
    data_std: float = math.nan
    held_std: float = math.nan

    @property
    def change(self) -> float:
        """Calibrated minus prior value."""
        return self.value - self.prior

    def as_document(self) -> dict[str, Any]:
        """``{"value", "std", "status", "prior", "formal_std", "std_data", "std_held"}``."""
        return {
            "value": self.value,
            "std": _num(self.std),
            "status": self.status,
            "prior": self.prior,
            "formal_std": _num(self.formal_std),
            "std_data": _num(self.data_std),
            "std_held": _num(self.held_std),
        }


@dataclass(frozen=True)
class FeatureSummary:
    """One feature's fit before and after the calibration.

    Attributes
    ----------
    kind : {"plane", "sphere"}
    description : str
        E.g. ``plane, tilt 90 deg, normal azimuth 270 deg``.
    n_points : int
        Returns used.
    n_passes : int
        Lines (or passes) that see it.
    rms_before_m, rms_after_m : float
        RMS residual of its returns with the prior and the calibrated mount (m).
    scatter_before_m, scatter_after_m : tuple of 2 float
        RMS scatter (horizontal, vertical) of where each line alone puts the feature
        (`kinsync.calibration.overlaps`), prior and calibrated mount (m).
    """

    kind: str
    description: str
    n_points: int
    n_passes: int
    rms_before_m: float
    rms_after_m: float
    scatter_before_m: tuple[float, float] = (math.nan, math.nan)
    scatter_after_m: tuple[float, float] = (math.nan, math.nan)

    def as_document(self) -> dict[str, Any]:
        """The ``--json`` entry of the feature."""
        return {
            "kind": self.kind,
            "description": self.description,
            "n_points": self.n_points,
            "n_passes": self.n_passes,
            "rms_before_m": self.rms_before_m,
            "rms_after_m": self.rms_after_m,
            "scatter_before_m": {
                "horizontal": _num(self.scatter_before_m[0]),
                "vertical": _num(self.scatter_before_m[1]),
            },
            "scatter_after_m": {
                "horizontal": _num(self.scatter_after_m[0]),
                "vertical": _num(self.scatter_after_m[1]),
            },
        }


@dataclass(frozen=True, eq=False)
class CalibrationResult(ReadOnlyArrays):
    """A mount calibration: the mount, each parameter's sigma and status, the evidence.

    Attributes
    ----------
    mount : Mount
        The calibrated mount (unobservable and fixed parameters at their prior values).
    prior : Mount
        The mount the calibration started from.
    parameters : tuple of ParameterEstimate
        All seven parameters, in the order of `kinsync.calibration.parameters`.
    sigma_method : str
        What ``std`` is (the jackknife over lines, or the formal sigma and why).
    correlation_names : tuple of str
        The estimated parameters, in the order of ``correlation``.
    correlation : ndarray, shape (k, k)
        Their correlation matrix.
    features : tuple of FeatureSummary
    residual_rms_before_m, residual_rms_after_m : float
        RMS residual over every feature's returns, prior and calibrated mount (m).
    unobservable_reasons : tuple of str
        Which parameters could not be told apart, in words.
    advice : tuple of str
        Which data would determine what could not be.
    lines : tuple of str
        The lines used (those with returns on a feature).
    iterations : int
        Gauss-Newton iterations of the full solution.
    overlaps_before, overlaps_after : tuple of LineOverlap
        Every (feature, line)'s offset from the feature, prior and calibrated mount.
    rejected_lines : tuple of (str, str)
        Lines given but not used, with the reason (none of their returns lie on a
        feature another line sees): left out of the adjustment and of the jackknife.
    held : HeldEffect or None
        How the held parameters' errors reach the estimates (None when nothing was
        estimated or nothing held).
    held_advice : tuple of str
        Held values whose error matters (taken as exact, or limiting an estimate), in
        words.
    uncertainty_notes : tuple of str
        What the calibrated mount's ``[uncertainty]`` leaves out, and which estimate the
        data give less well than the mount stated.
    warnings : tuple of str
        What to know before trusting the estimates: a file holding two passes, lines
        driven both ways that share no wall (a grossly wrong start), a fit worse than the
        start (`kinsync.calibration.gross`).
    sigma_honest : bool
        Whether ``std`` holds the errors a line shares (the jackknife over 5 or more
        lines); False for the formal sigma (fewer lines, or none could be
        determined), which trajectory errors correlated over a line make 3-30 times
        too small (2 lines: lever y 41 sigma off its truth): ``sigma_method`` says why.
    """

    mount: Mount
    prior: Mount
    parameters: tuple[ParameterEstimate, ...]
    sigma_method: str
    correlation_names: tuple[str, ...]
    correlation: FloatArray
    features: tuple[FeatureSummary, ...]
    residual_rms_before_m: float
    residual_rms_after_m: float
    unobservable_reasons: tuple[str, ...]
    advice: tuple[str, ...]
    lines: tuple[str, ...]
    iterations: int
    overlaps_before: tuple[LineOverlap, ...] = ()
    overlaps_after: tuple[LineOverlap, ...] = ()
    rejected_lines: tuple[tuple[str, str], ...] = ()
    held: HeldEffect | None = None
    held_advice: tuple[str, ...] = ()
    uncertainty_notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    sigma_honest: bool = True

    def __post_init__(self) -> None:
        # Own read-only copy, as every result's arrays (the held effect's are its own).
        object.__setattr__(self, "correlation", readonly_array(self.correlation))

    def parameter(self, name: str) -> ParameterEstimate:
        """The estimate called ``name`` (e.g. ``latency_ms``).

        Parameters
        ----------
        name : str
            One of `kinsync.mount.MOUNT_PARAMETER_NAMES` (``boresight_roll_deg`` ..
            ``latency_ms``); the unit is in the name.

        Returns
        -------
        ParameterEstimate
            Its value, prior and standard deviation in the report units (deg, m, ms).

        Raises
        ------
        KeyError
            No parameter of that name.
        """
        for p in self.parameters:
            if p.name == name:
                return p
        msg = f"no parameter {name!r}"
        raise KeyError(msg)

    def as_document(self) -> dict[str, Any]:
        """The ``kinsync calibrate mount --json`` document."""
        return {
            "parameters": {p.name: p.as_document() for p in self.parameters},
            "sigma_method": self.sigma_method,
            "sigma_honest": self.sigma_honest,
            "correlation": {
                "names": list(self.correlation_names),
                "matrix": np.round(self.correlation, 6).tolist(),
            },
            "features": [f.as_document() for f in self.features],
            "residual_rms_before_m": self.residual_rms_before_m,
            "residual_rms_after_m": self.residual_rms_after_m,
            "unobservable": list(self.unobservable_reasons),
            "advice": list(self.advice),
            "lines": list(self.lines),
            "rejected_lines": [
                {"line": name, "reason": reason} for name, reason in self.rejected_lines
            ],
            "held": {} if self.held is None else self.held.document(),
            "held_advice": list(self.held_advice),
            "uncertainty_notes": list(self.uncertainty_notes),
            "warnings": list(self.warnings),
            "mount": self.mount.as_document(),
        }
