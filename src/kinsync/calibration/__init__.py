"""Mount self-calibration from survey data: boresight, lever arm and latency.

The lines of a survey (`kinsync.calibration.lines.ScanLine`: scanner-frame returns
with times, and the trajectory) are georeferenced with a candidate mount; features
seen by several lines (spheres, planar patches) must then coincide. The estimator
solves for the mount parameters with the features as nuisance parameters, reports an
honest standard deviation (errors correlated within a line) and says which parameters
the data could not determine.

The names below load their modules on first use (`kinsync._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kinsync._lazy import lazy_exports

if TYPE_CHECKING:
    from kinsync.calibration.estimator import CalibrationOptions, calibrate_mount, find_features
    from kinsync.calibration.lines import ScanLine
    from kinsync.calibration.planes import PatchOptions
    from kinsync.calibration.planning import (
        NavigationErrors,
        PlannedParameter,
        PlanResult,
        plan_calibration,
    )
    from kinsync.calibration.result import (
        CalibrationResult,
        FeatureSummary,
        ParameterEstimate,
        Status,
    )
    from kinsync.calibration.spheres import SphereOptions

__all__ = [
    "CalibrationOptions",
    "CalibrationResult",
    "FeatureSummary",
    "NavigationErrors",
    "ParameterEstimate",
    "PatchOptions",
    "PlanResult",
    "PlannedParameter",
    "ScanLine",
    "SphereOptions",
    "Status",
    "calibrate_mount",
    "find_features",
    "plan_calibration",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "ScanLine": "kinsync.calibration.lines",
        "CalibrationOptions": "kinsync.calibration.estimator",
        "calibrate_mount": "kinsync.calibration.estimator",
        "find_features": "kinsync.calibration.estimator",
        "CalibrationResult": "kinsync.calibration.result",
        "FeatureSummary": "kinsync.calibration.result",
        "ParameterEstimate": "kinsync.calibration.result",
        "Status": "kinsync.calibration.result",
        "PatchOptions": "kinsync.calibration.planes",
        "SphereOptions": "kinsync.calibration.spheres",
        "NavigationErrors": "kinsync.calibration.planning",
        "PlanResult": "kinsync.calibration.planning",
        "PlannedParameter": "kinsync.calibration.planning",
        "plan_calibration": "kinsync.calibration.planning",
    },
)
