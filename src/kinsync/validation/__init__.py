"""Validation of a georeferenced cloud (SPEC section 7).

- `kinsync.validation.targets`: control targets extracted from the cloud.
- `kinsync.validation.differences`: their differences to the surveyed control points
  in the vehicle frame (X right, Y forward, Z up).
- `kinsync.validation.signatures`: time-error and heading signatures tested in one
  mixed model.
- `kinsync.validation.control_points`: `ControlPoints`, the surveyed reference.
- `kinsync.validation.control_report`: `validate_control_points`, the whole check on
  containers, and its `ControlPointReport`.
- `kinsync.validation.flatness`: a wall's plane fit and its curvature test.

Streaming cloud files through these checks is a pipeline: `kinsync.pipelines.validation`.
"""

from kinsync.validation.control_points import ControlPoints
from kinsync.validation.control_report import ControlPointReport, validate_control_points
from kinsync.validation.differences import ControlPointDifference, control_point_differences
from kinsync.validation.flatness import Box, FlatnessResult, fit_wall, select_box
from kinsync.validation.signatures import (
    SignatureTest,
    SignatureTests,
    pass_labels,
    signature_tests,
)
from kinsync.validation.targets import (
    CentreMethod,
    CloudPoints,
    MissingTarget,
    TargetObservation,
    extract_targets,
    otsu_threshold,
)

__all__ = [
    "Box",
    "CentreMethod",
    "CloudPoints",
    "ControlPointDifference",
    "ControlPointReport",
    "ControlPoints",
    "FlatnessResult",
    "MissingTarget",
    "SignatureTest",
    "SignatureTests",
    "TargetObservation",
    "control_point_differences",
    "extract_targets",
    "fit_wall",
    "otsu_threshold",
    "pass_labels",
    "select_box",
    "signature_tests",
    "validate_control_points",
]
