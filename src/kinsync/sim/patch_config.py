"""Set-up of the patch-test simulator (`kinsync.sim.patch_test`): scenarios and defaults.

`PatchTestConfig` holds everything a simulated patch test depends on: the scenario,
the injected mount errors, the drive (speeds, passes, platform motion), the navigation
errors and the scanner. Fields left None take the scenario's default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from kinsync._typing import FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.io.sbet import SECONDS_PER_WEEK
from kinsync.mount import Mount
from kinsync.sim._common import Vector3, _non_negative, _vector3
from kinsync.sim.patch_route import PlatformMotion

__all__ = ["SCENARIOS", "PatchTestConfig", "Scenario"]

Scenario = Literal["vehicle", "vessel"]
SCENARIOS: tuple[Scenario, ...] = ("vehicle", "vessel")

_DEFAULT_START_GPS_S = 2345 * SECONDS_PER_WEEK + 216_000.0
"""GPS week 2345, Tuesday 12:00:00 GPS (2024-12-17)."""


@dataclass(frozen=True)
class _ScenarioDefaults:
    nominal_mount: Mount
    speeds_m_s: tuple[float, ...]
    spheres: bool
    motion: PlatformMotion
    street_azimuth_deg: float
    max_range_m: float


_DEFAULTS: dict[str, _ScenarioDefaults] = {
    "vehicle": _ScenarioDefaults(
        nominal_mount=Mount(
            lever_arm_body_m=(-0.80, 0.0, -1.75),
            boresight_rpy_deg=(0.0, -30.0, 30.0),
            profiler_azimuth_deg=0.0,
        ),
        speeds_m_s=(5.0, 12.0),
        spheres=False,
        motion=PlatformMotion(
            roll_amplitude_deg=0.3, roll_period_s=2.3, pitch_amplitude_deg=0.2, pitch_period_s=1.7
        ),
        street_azimuth_deg=20.0,
        max_range_m=80.0,
    ),
    "vessel": _ScenarioDefaults(
        nominal_mount=Mount(
            lever_arm_body_m=(0.60, 1.10, -3.00),
            boresight_rpy_deg=(-90.0, 0.0, 20.0),
            profiler_azimuth_deg=0.0,
        ),
        speeds_m_s=(2.0, 4.0),
        spheres=True,
        motion=PlatformMotion(
            roll_amplitude_deg=4.0,
            roll_period_s=7.0,
            pitch_amplitude_deg=1.5,
            pitch_period_s=5.0,
            heave_amplitude_m=0.15,
            heave_period_s=6.0,
        ),
        street_azimuth_deg=325.0,
        max_range_m=120.0,
    ),
}


@dataclass(frozen=True)
class PatchTestConfig:
    """Set-up of a simulated patch test (defaults: a realistic survey).

    Fields left None take the scenario's default when the config is made (so
    ``dataclasses.replace(config, scenario=...)`` keeps the other scenario's values:
    make a new config to change scenario).

    Attributes
    ----------
    scenario : {"vehicle", "vessel"}
        Town block by car, or harbour channel by boat (module docstring).
    seed : int
        Seed of the trajectory errors and the range noise (same seed, same data).
    boresight_error_rpy_deg : tuple of 3 float
        True boresight minus nominal, as DIN 9300 roll, pitch, yaw angles (deg).
    lever_arm_error_body_m : tuple of 3 float
        True lever arm minus nominal, body frame FRD (m).
    latency_error_s : float
        True latency minus the nominal mount's (s); > 0: the navigation lags.
    nominal_mount : Mount or None
        The mount the user starts from (needs ``[profiler] azimuth_deg``); None: the
        scenario's (vehicle: lever arm (-0.80, 0, -1.75) m, boresight (0, -30, 30) deg;
        vessel: (0.60, 1.10, -3.00) m, (-90, 0, 20) deg; latency 0).
    speeds_m_s : tuple of float or None
        Cruise speed of each block of lines (m/s), driven in order; None: vehicle
        (5, 12), vessel (2, 4).
    passes_per_direction : int
        Lines each way per speed (>= 1): ``2 * passes * len(speeds)`` lines in all.
    spheres : bool or None
        Put two spheres in the scene; None: vehicle no, vessel yes.
    motion : PlatformMotion or None
        Roll, pitch, heave; None: vehicle 0.3 deg / 2.3 s roll and 0.2 deg / 1.7 s pitch,
        vessel 4 deg / 7 s roll, 1.5 deg / 5 s pitch, 0.15 m / 6 s heave.
    street_azimuth_deg : float or None
        Azimuth of the outbound lines (deg); None: vehicle 20, vessel 325.
    origin_lat_lon_h : tuple of 3 float
        Geodetic origin of the scene (deg, deg, m ellipsoidal), on the ground / water.
    start_gps_s : float
        GPS time of the first navigation record (s); default GPS week 2345, Tuesday
        12:00 (the whole drive stays within that week).
    nav_rate_hz : float
        Navigation record rate (Hz).
    std_pos_ned_m : tuple of 3 float
        Position error sigma of the navigation solution, N, E, D (m).
    std_att_deg : tuple of 3 float
        Attitude error sigma about N, E, D (deg): roll/pitch-like, roll/pitch-like,
        heading.
    error_corr_time_s : float
        Correlation time of the navigation errors (s).
    range_noise_m : float
        Range noise along the beam, 1 sigma (m).
    profile_rate_hz : float
        Mirror turns per second (profiles per second).
    angular_step_deg : float
        Angle between beams of a profile (deg); the profile is the full circle.
    density : float
        Fraction of the beams simulated, in (0, 1] (regular thinning; 1: all).
    min_range_m : float
        Returns nearer than this are dropped (m).
    max_range_m : float or None
        Returns farther than this are dropped (m); None: vehicle 80, vessel 120.
    line_margin_s : float
        Each line's navigation extends this long beyond its first and last return (s).
    """

    scenario: Scenario = "vehicle"
    seed: int = 1
    boresight_error_rpy_deg: Vector3 = (0.25, -0.30, 0.40)
    lever_arm_error_body_m: Vector3 = (0.03, -0.02, 0.04)
    latency_error_s: float = 0.005
    nominal_mount: Mount | None = None
    speeds_m_s: tuple[float, ...] | None = None
    passes_per_direction: int = 2
    spheres: bool | None = None
    motion: PlatformMotion | None = None
    street_azimuth_deg: float | None = None
    origin_lat_lon_h: Vector3 = (46.8, -71.2, 10.0)
    start_gps_s: float = _DEFAULT_START_GPS_S
    nav_rate_hz: float = 200.0
    std_pos_ned_m: Vector3 = (0.02, 0.02, 0.03)
    std_att_deg: Vector3 = (0.005, 0.005, 0.01)
    error_corr_time_s: float = 20.0
    range_noise_m: float = 0.01
    profile_rate_hz: float = 50.0
    angular_step_deg: float = 0.5
    density: float = 1.0
    min_range_m: float = 1.0
    max_range_m: float | None = None
    line_margin_s: float = 2.0

    def __post_init__(self) -> None:
        if self.scenario not in SCENARIOS:
            msg = f"patch test: scenario must be 'vehicle' or 'vessel', got {self.scenario!r}"
            raise InputError(msg)
        d = _DEFAULTS[self.scenario]
        for name in ("nominal_mount", "speeds_m_s", "spheres", "motion"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, getattr(d, name))
        if self.street_azimuth_deg is None:
            object.__setattr__(self, "street_azimuth_deg", d.street_azimuth_deg)
        if self.max_range_m is None:
            object.__setattr__(self, "max_range_m", d.max_range_m)
        self._check_counts()
        self._check_mount()
        for name in ("boresight_error_rpy_deg", "lever_arm_error_body_m", "origin_lat_lon_h"):
            object.__setattr__(self, name, _vector3(getattr(self, name), f"patch test {name}"))
        for name in ("std_pos_ned_m", "std_att_deg"):
            vals = _vector3(getattr(self, name), f"patch test {name}")
            for i, v in enumerate(vals):
                _non_negative(v, f"patch test {name}[{i}]")
            object.__setattr__(self, name, vals)
        if max(abs(v) for v in self.boresight_error_rpy_deg) > 5.0:
            msg = (
                f"patch test: boresight errors {self.boresight_error_rpy_deg} deg; keep them "
                "within 5 deg (a patch test refines a known mount)"
            )
            raise InputError(msg)
        if max(abs(v) for v in self.lever_arm_error_body_m) > 1.0:
            msg = f"patch test: lever-arm errors {self.lever_arm_error_body_m} m; keep within 1 m"
            raise InputError(msg)
        if abs(finite_number(self.latency_error_s, "patch test latency_error_s")) > 0.5:
            msg = f"patch test: latency error {self.latency_error_s} s; keep within 0.5 s"
            raise InputError(msg)
        if abs(self.origin_lat_lon_h[0]) > 80.0:
            msg = f"patch test: origin latitude {self.origin_lat_lon_h[0]} deg; keep within 80"
            raise InputError(msg)
        self._check_scanner()

    def _check_counts(self) -> None:
        seed = self.seed
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            msg = f"patch test: seed must be a whole number >= 0, got {seed!r}"
            raise InputError(msg)
        p = self.passes_per_direction
        if isinstance(p, bool) or not isinstance(p, int | np.integer) or not 1 <= p <= 20:
            msg = f"patch test: passes_per_direction must be a whole number 1..20, got {p!r}"
            raise InputError(msg)
        speeds = tuple(self.speeds_m_s or ())
        if not 1 <= len(speeds) <= 5:
            msg = f"patch test: give 1 to 5 speeds, got {len(speeds)}"
            raise InputError(msg)
        for v in speeds:
            if not 0.2 <= positive_number(v, "patch test speeds_m_s") <= 40.0:
                msg = f"patch test: speed {v} m/s outside [0.2, 40] m/s"
                raise InputError(msg)
        object.__setattr__(self, "speeds_m_s", tuple(float(v) for v in speeds))
        finite_number(self.street_azimuth_deg, "patch test street_azimuth_deg")
        finite_number(self.start_gps_s, "patch test start_gps_s")
        if self.start_gps_s < 0.0:
            msg = f"patch test: start_gps_s must be >= 0, got {self.start_gps_s}"
            raise InputError(msg)

    def _check_mount(self) -> None:
        m = self.nominal_mount
        if not isinstance(m, Mount):
            msg = f"patch test: nominal_mount must be a Mount, got {type(m).__name__}"
            raise InputError(msg)
        if m.profiler_azimuth_deg is None:
            msg = "patch test: the nominal mount needs a [profiler] azimuth_deg (2-D profiler)"
            raise InputError(msg)
        if not isinstance(self.motion, PlatformMotion):
            msg = f"patch test: motion must be a PlatformMotion, got {type(self.motion).__name__}"
            raise InputError(msg)

    def _check_scanner(self) -> None:
        positive_number(self.nav_rate_hz, "patch test nav_rate_hz")
        if not 10.0 <= self.nav_rate_hz <= 1000.0:
            msg = f"patch test: nav_rate_hz {self.nav_rate_hz} outside [10, 1000] Hz"
            raise InputError(msg)
        positive_number(self.error_corr_time_s, "patch test error_corr_time_s")
        _non_negative(self.range_noise_m, "patch test range_noise_m")
        if not 1.0 <= positive_number(self.profile_rate_hz, "patch test profile_rate_hz") <= 500:
            msg = f"patch test: profile_rate_hz {self.profile_rate_hz} outside [1, 500] Hz"
            raise InputError(msg)
        step = positive_number(self.angular_step_deg, "patch test angular_step_deg")
        if not 0.01 <= step <= 10.0:
            msg = f"patch test: angular_step_deg {step} outside [0.01, 10] deg"
            raise InputError(msg)
        dens = positive_number(self.density, "patch test density")
        if dens > 1.0:
            msg = f"patch test: density must lie in (0, 1] (fraction of beams), got {dens}"
            raise InputError(msg)
        lo = positive_number(self.min_range_m, "patch test min_range_m")
        if positive_number(self.max_range_m, "patch test max_range_m") <= lo:
            msg = "patch test: max_range_m must exceed min_range_m"
            raise InputError(msg)
        _non_negative(self.line_margin_s, "patch test line_margin_s")

    @property
    def mount_nominal(self) -> Mount:
        """The mount the user knows (what the calibration starts from)."""
        assert self.nominal_mount is not None
        return self.nominal_mount

    @property
    def mount_true(self) -> Mount:
        """The true mount: nominal plus the injected errors."""
        m = self.mount_nominal
        return replace(
            m,
            boresight_rpy_deg=_add3(m.boresight_rpy_deg, self.boresight_error_rpy_deg),
            lever_arm_body_m=_add3(m.lever_arm_body_m, self.lever_arm_error_body_m),
            latency_s=m.latency_s + self.latency_error_s,
        )

    def with_nominal(self, nominal: Mount) -> PatchTestConfig:
        """The same survey and true mount, started from ``nominal``.

        ``nominal`` is e.g. an earlier calibration's result: the injected errors become
        the truth minus ``nominal``.
        """
        true = self.mount_true

        def minus(a: Vector3, b: Vector3) -> Vector3:
            return (a[0] - b[0], a[1] - b[1], a[2] - b[2])

        return replace(
            self,
            nominal_mount=nominal,
            boresight_error_rpy_deg=minus(true.boresight_rpy_deg, nominal.boresight_rpy_deg),
            lever_arm_error_body_m=minus(true.lever_arm_body_m, nominal.lever_arm_body_m),
            latency_error_s=true.latency_s - nominal.latency_s,
        )

    @property
    def profile_period_s(self) -> float:
        """Mirror period T (s)."""
        return 1.0 / self.profile_rate_hz

    def angles_rad(self) -> FloatArray:
        """Mirror angles of one profile from nadir (rad), shape (A,): ``[-pi, pi)``."""
        n = math.floor(360.0 / self.angular_step_deg + 1e-9)
        out: FloatArray = np.radians(-180.0 + self.angular_step_deg * np.arange(n))
        return out


def _add3(a: Vector3, b: Vector3) -> Vector3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])
