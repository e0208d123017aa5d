"""Loosely coupled INS/GNSS (SPEC section 6).

Earth model, strapdown mechanisation, 21-state (27 with scale factors, one more after a
levelled standstill) error-state Kalman filter with GNSS position/velocity updates, and
the Rauch–Tung–Striebel smoother.

Frames: body X forward, Y right, Z down; navigation frame local NED; position as
geodetic latitude, longitude (rad inside the algorithms, deg at the file boundary) and
ellipsoidal height (WGS84).

The names below load their modules on first use (`kinsync._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kinsync._lazy import lazy_exports

if TYPE_CHECKING:
    from kinsync.ins.alignment import align_static_gnss_heading
    from kinsync.ins.checks import check_gnss_rejections, check_inputs
    from kinsync.ins.compare import Comparison, compare_to_truth
    from kinsync.ins.config import InsConfig
    from kinsync.ins.file_rows import FileRows
    from kinsync.ins.filter import GnssStatus, run_ins
    from kinsync.ins.measurements import GnssData, ImuData
    from kinsync.ins.result import InsResult
    from kinsync.ins.solution import InitialState, NavSolution
    from kinsync.ins.strapdown import free_inertial

__all__ = [
    "Comparison",
    "FileRows",
    "GnssData",
    "GnssStatus",
    "ImuData",
    "InitialState",
    "InsConfig",
    "InsResult",
    "NavSolution",
    "align_static_gnss_heading",
    "check_gnss_rejections",
    "check_inputs",
    "compare_to_truth",
    "free_inertial",
    "run_ins",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "GnssData": "kinsync.ins.measurements",
        "ImuData": "kinsync.ins.measurements",
        "InsConfig": "kinsync.ins.config",
        "FileRows": "kinsync.ins.file_rows",
        "InitialState": "kinsync.ins.solution",
        "NavSolution": "kinsync.ins.solution",
        "GnssStatus": "kinsync.ins.filter",
        "InsResult": "kinsync.ins.result",
        "run_ins": "kinsync.ins.filter",
        "free_inertial": "kinsync.ins.strapdown",
        "align_static_gnss_heading": "kinsync.ins.alignment",
        "check_gnss_rejections": "kinsync.ins.checks",
        "check_inputs": "kinsync.ins.checks",
        "Comparison": "kinsync.ins.compare",
        "compare_to_truth": "kinsync.ins.compare",
    },
)
