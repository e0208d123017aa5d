"""Direct georeferencing of scanner points (SPEC section 5).

- `kinsync.georef.trajectory`: `GeorefTrajectory`, the trajectory prepared once
  (ECEF positions and velocities, body -> ECEF attitudes, latency applied).
- `kinsync.georef.kernel`: `georeference`, the compiled kernel, and
  `georeference_numpy`, its numpy reference.
- `kinsync.georef.profile`: 2D profile points (range, mirror angle) into the scanner
  frame and georeferenced.

Streaming a file through the kernel (chunks, process pools, Dask) is a pipeline:
`kinsync.pipelines.georef`.
"""

from kinsync.georef.kernel import (
    PositionMethod,
    georeference,
    georeference_numpy,
    validated_scanner_points,
)
from kinsync.georef.profile import georeference_profile, profile_points_to_scanner
from kinsync.georef.trajectory import GeorefTrajectory

__all__ = [
    "GeorefTrajectory",
    "PositionMethod",
    "georeference",
    "georeference_numpy",
    "georeference_profile",
    "profile_points_to_scanner",
    "validated_scanner_points",
]
