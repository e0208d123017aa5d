"""Bad arguments to the public Python API raise InputError naming them, not numpy's errors.

Each case raised a ValueError, TypeError or AttributeError from deep inside numpy or
kinsync (or, for complex quaternions, dropped the imaginary part with a ComplexWarning).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
import pytest

from kinsync import Mount, Trajectory
from kinsync.calibration import CalibrationOptions, calibrate_mount, plan_calibration
from kinsync.clock import ProfileClock, message_transmission_time_s
from kinsync.errors import InputError
from kinsync.latency import SpherePass

N = 10
T_S: np.ndarray = 1.4e9 + np.arange(N) * 0.1
Q = np.tile([1.0, 0.0, 0.0, 0.0], (N, 1))
LLH = np.tile([46.8, -71.2, 10.0], (N, 1))
ZEROS = np.zeros(N)


def _trajectory() -> Trajectory:
    return Trajectory(T_S, Q, lat_lon_h=LLH)


CASES: dict[str, tuple[Callable[[], object], str]] = {
    "from_euler velocities as text": (
        lambda: Trajectory.from_euler(
            T_S, ZEROS, ZEROS, ZEROS, lat_lon_h=LLH, vel_ned_m_s=[["a"] * 3] * N
        ),
        r"^trajectory vel_ned_m_s: expected numbers",
    ),
    "from_euler velocities of another shape": (
        lambda: Trajectory.from_euler(
            T_S, ZEROS, ZEROS, ZEROS, lat_lon_h=LLH, vel_ned_m_s=np.zeros((N, 2))
        ),
        r"^trajectory vel_ned_m_s: expected shape \(10, 3\)",
    ),
    "shifted by text": (
        lambda: _trajectory().shifted("1"),  # type: ignore[arg-type]
        r"^time shift dt_s: expected a number, got '1'",
    ),
    "shifted by NaN": (
        lambda: _trajectory().shifted(float("nan")),
        r"^time shift dt_s: must be finite",
    ),
    "SpherePass axis as text": (
        lambda: SpherePass("p", 6.0, np.zeros((20, 3)), axis_ned="0,0,1"),  # type: ignore[arg-type]
        r"^p: axis_ned: expected 3 finite numbers \(N, E, D\), non-zero, got '0,0,1'",
    ),
    "ProfileClock.time_s of text": (
        lambda: ProfileClock(1.4e9, 0.03).time_s(["a"], [0.0]),
        r"^profile clock time_s: profile: expected numbers, got <U1",
    ),
    "message_transmission_time_s of a byte count": (
        lambda: message_transmission_time_s(38, 115200),  # type: ignore[arg-type]
        r"^sentence: expected the NMEA sentence as text .* got 38; .*serial_transmission_time_s",
    ),
    "calibrate_mount without a mount": (
        lambda: calibrate_mount([], None, CalibrationOptions()),  # type: ignore[arg-type]
        r"^mount: expected a kinsync\.Mount, .* got None",
    ),
    "calibrate_mount of numbers": (
        lambda: calibrate_mount([1, 2], Mount(), CalibrationOptions()),  # type: ignore[list-item]
        r"^lines: item at index 0 \(0-based\) is a int, not a ScanLine",
    ),
    "plan_calibration without a mount": (
        lambda: plan_calibration([], None),  # type: ignore[arg-type]
        r"^mount: expected a kinsync\.Mount",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_argument_raises_input_error_naming_it(case: str) -> None:
    call, match = CASES[case]
    with pytest.raises(InputError, match=match):
        call()


@pytest.mark.parametrize(
    ("field", "kwargs"),
    [
        ("q_body_to_ned", {"q_body_to_ned": Q + 0.5j}),
        ("lat_lon_h", {"lat_lon_h": LLH.astype(complex)}),
        ("vel_ned_m_s", {"vel_ned_m_s": np.zeros((N, 3), complex)}),
    ],
)
def test_complex_values_are_refused_like_complex_times(
    field: str, kwargs: dict[str, np.ndarray]
) -> None:
    """Complex quaternions were taken, their imaginary part dropped with a ComplexWarning."""
    args: dict[str, object] = {"q_body_to_ned": Q, "lat_lon_h": LLH, **kwargs}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way
        with pytest.raises(InputError, match=rf"^trajectory {field}: expected real numbers"):
            Trajectory(T_S, **args)  # type: ignore[arg-type]
