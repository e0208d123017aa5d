"""Method A: total IMU-LiDAR latency from a sphere scanned on a rotating table (SPEC section 2).

- `kinsync.latency.passes`: `SpherePass`, one pass of the sphere at one table rate.
- `kinsync.latency.sphere`: `estimate_latency_sphere`, the latency from passes at
  opposite rates, with its σ, per-rate figures and the passes it rejected.
- `kinsync.latency.pairing`: the passes paired by rate and axis; `RejectedPass`, a pass
  left out of the estimate.
- `kinsync.latency.rate_check`: `check_pass_rates`, the stated table rates against the
  rates the data show (sign convention, rad/s, ENU mix-ups); `RatesUncheckedWarning`,
  issued when no data could check some passes' rates.
- `kinsync.latency.roi`: `crop_passes`, the points of each pass inside a region of
  interest, and `RoiCrop`, what it left out.
- `kinsync.latency.planning`: `plan_latency_experiment`, the σ a table design will give.

Reading pass folders is `kinsync.io.passes.read_passes`.

The names below load their modules on first use (`kinsync._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kinsync._lazy import lazy_exports

if TYPE_CHECKING:
    from kinsync.latency.pairing import RejectedPass
    from kinsync.latency.passes import SpherePass
    from kinsync.latency.planning import LatencyPlan, RatePlan, TableDesign, plan_latency_experiment
    from kinsync.latency.rate_check import RateMismatch, RatesUncheckedWarning, check_pass_rates
    from kinsync.latency.sphere import RateLatency, SphereLatencyResult, estimate_latency_sphere

__all__ = [
    "LatencyPlan",
    "RateLatency",
    "RateMismatch",
    "RatePlan",
    "RatesUncheckedWarning",
    "RejectedPass",
    "SphereLatencyResult",
    "SpherePass",
    "TableDesign",
    "check_pass_rates",
    "estimate_latency_sphere",
    "plan_latency_experiment",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "SpherePass": "kinsync.latency.passes",
        "RateLatency": "kinsync.latency.sphere",
        "RejectedPass": "kinsync.latency.pairing",
        "SphereLatencyResult": "kinsync.latency.sphere",
        "estimate_latency_sphere": "kinsync.latency.sphere",
        "RateMismatch": "kinsync.latency.rate_check",
        "RatesUncheckedWarning": "kinsync.latency.rate_check",
        "check_pass_rates": "kinsync.latency.rate_check",
        "LatencyPlan": "kinsync.latency.planning",
        "RatePlan": "kinsync.latency.planning",
        "TableDesign": "kinsync.latency.planning",
        "plan_latency_experiment": "kinsync.latency.planning",
    },
)
