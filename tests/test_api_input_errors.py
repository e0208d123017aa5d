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
from kinsync.ins import GnssData
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


def test_absurd_ellipsoidal_heights_are_refused_naming_the_row() -> None:
    """Heights of 1e30 m (Trajectory) and 1e7 m (GnssData) were taken."""
    llh = LLH.copy()
    llh[:, 2] = 20_000.0  # an aircraft at 20 km: taken
    llh[-1, 2] = 1.0e5  # the bound itself: taken
    Trajectory(T_S, Q, lat_lon_h=llh)
    llh[3, 2] = 1.0e30
    with pytest.raises(InputError, match=r"^trajectory lat_lon_h: height 1e\+30 m .* in row 3"):
        Trajectory(T_S, Q, lat_lon_h=llh)
    with pytest.raises(InputError, match=r"^trajectory origin_lat_lon_h: height -200000\.0 m"):
        Trajectory(T_S, Q, pos_ned_m=np.zeros((N, 3)), origin_lat_lon_h=(46.8, -71.2, -2e5))
    h = np.full(N, 10.0)
    h[4] = 1.0e7
    lat, lon, std = np.full(N, 46.8), np.full(N, -71.2), np.full((N, 3), 0.02)
    with pytest.raises(InputError, match=r"^GNSS h_m: height 10000000\.0 m .* in row 4 \(0-based"):
        GnssData(T_S, lat, lon, h, std)


@pytest.mark.parametrize(
    ("angle_rad", "match"),
    [
        (135.0, r"angle_rad\[1\] = 135\.0 is not a finite angle within one turn"),
        (float("nan"), r"angle_rad\[1\] = nan is not a finite angle"),
    ],
)
def test_profile_clock_refuses_degrees_and_nan_as_the_mount_does(
    angle_rad: float, match: str
) -> None:
    """ProfileClock.time_s took 135 (degrees) and NaN; Mount.profile_to_scanner refused them."""
    clock = ProfileClock(1.4e9, 0.030545)
    angles = [0.0, angle_rad]
    with pytest.raises(InputError, match=r"^profile_to_scanner: "):
        Mount(profiler_azimuth_deg=0.0).profile_to_scanner(angle_rad=angles, range_m=[5.0, 5.0])
    with pytest.raises(InputError, match=rf"^profile clock time_s: {match}"):
        clock.time_s([0, 1], angles)
    turn = 2.0 * np.pi  # one turn either way is taken, as by the mount
    t = clock.time_s([0, 1], [-turn, turn])
    np.testing.assert_allclose(t - 1.4e9, [-0.030545, 2 * 0.030545], rtol=0, atol=1e-6)
