"""Settings of the rotating-table simulator (`kinsync.sim.rotating_table`) and point labels.

`RotatingTableConfig` holds the table, scanner, scene, IMU and acquisition settings of
a simulated Method A experiment (SPEC section 2), each checked on construction; the
``LABEL_*`` constants say what each simulated point hit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kinsync._validate import finite_number
from kinsync.budget import serial_transmission_time_s
from kinsync.errors import InputError
from kinsync.latency.planning import (
    max_usable_rate_deg_s,
    too_fast_text,
    worst_sphere_points_per_pass,
)

__all__ = [
    "LABEL_FLOOR",
    "LABEL_NAMES",
    "LABEL_SPHERE",
    "LABEL_STAND",
    "LABEL_STRAY",
    "RotatingTableConfig",
    "max_usable_rate_deg_s",
    "too_fast_text",
    "worst_sphere_points_per_pass",
]

LABEL_SPHERE = 0
"""Point label: return from the sphere."""


LABEL_STAND = 1
"""Point label: return from the stand."""


LABEL_FLOOR = 2
"""Point label: return from the floor."""


LABEL_STRAY = 3
"""Point label: stray point (multipath, dust, mixed pixels)."""


LABEL_NAMES = ("sphere", "stand", "floor", "stray")
"""Label names by label value."""


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise InputError(f"rotating-table config: {message}")


def _finite(value: float, name: str) -> float:
    return finite_number(value, f"rotating-table config: {name}")


@dataclass(frozen=True)
class RotatingTableConfig:
    """Set-up of a simulated rotating-table latency test (defaults: the published one).

    Attributes
    ----------
    latency_s : float
        IMU internal latency tau_imu (s); the total latency adds the FIFO delay.
    fifo_bytes : int
        Depth of the serial receive FIFO (bytes, >= 0); adds ``bytes * 10 / baud``.
    baud : float
        Serial line rate (bit/s), 8N1 frames.
    rates_deg_s : tuple of float
        Table rate magnitudes (deg/s, > 0, at most `max_rate_deg_s`); each is simulated
        in both directions.
    passes : int
        Passes per rate and direction (>= 1).
    seed : int
        Seed of the random generator; the simulation is deterministic for a seed.
    profile_rate_hz : float
        Mirror revolutions (profiles) per second.
    angular_step_deg : float
        Angle between consecutive beams of a profile (deg).
    range_noise_m : float
        Standard deviation of the range noise along the beam (m).
    imu_rate_hz : float
        Attitude record rate (Hz).
    imu_attitude_noise_deg : float
        White attitude noise of each record, per axis (deg, 1 sigma).
    pass_attitude_error_deg : float
        Attitude error constant over each pass and drawn anew for the next, about each
        NED axis (tilt about North and East, heading about Down; deg, 1 sigma): the
        slowly varying error of an INS, shared by every record of a pass. Drawn from
        its own random stream, so turning it on leaves every other draw of a seed as
        it was. Default 0.
    rate_regulation_noise_rel : float
        Relative RMS noise of the table rate (smooth: three random sinusoids).
    levelling_error_arcsec_max : float
        Maximum tilt of the table axis from +Down (arcsec); drawn uniformly.
    optical_centre_offset_max_m : float
        Maximum distance of the scanner's optical centre from the axis (m); drawn
        uniformly over the disc.
    boresight_rpy_deg : tuple of 3 float
        Boresight scanner -> body (DIN 9300 roll, pitch, yaw, deg); small angles.
    sphere_radius_m : float
        Sphere radius (m); 0.1 for the 0.20 m diameter sphere.
    sphere_range_m : float
        Horizontal distance of the sphere centre from the table axis (m).
    sphere_elevation_m : float
        Height of the sphere centre above the scanner's optical centre (m).
    stand_radius_m : float
        Radius of the vertical stand under the sphere (m).
    floor_below_sphere_m : float
        Depth of the floor below the sphere centre (m).
    roi_half_width_m : float
        Half width of the exported box around the sphere centre (m).
    stray_fraction : float
        Stray points added per exported return (0 to 0.5).
    pass_margin_deg : float
        Table angle added before and after the box is in the scan plane (deg).
    pass_gap_s : float
        Time between two passes (s, >= 0.5).
    t_start_s : float
        GPS time of the first pass (s).
    site_lat_lon_h : tuple of 3 float
        Geodetic position of the table (lat_deg, lon_deg, h_m); labels the attitude
        trajectory only.
    """

    latency_s: float = 0.00421
    fifo_bytes: int = 0
    baud: float = 115200.0
    rates_deg_s: tuple[float, ...] = (2.0, 4.0, 6.0, 10.0, 14.0, 18.0)
    passes: int = 15
    seed: int = 1
    profile_rate_hz: float = 50.0
    angular_step_deg: float = 0.2
    range_noise_m: float = 0.002
    imu_rate_hz: float = 100.0
    imu_attitude_noise_deg: float = 0.001
    pass_attitude_error_deg: float = 0.0
    rate_regulation_noise_rel: float = 5e-4
    levelling_error_arcsec_max: float = 15.0
    optical_centre_offset_max_m: float = 5e-4
    boresight_rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sphere_radius_m: float = 0.1
    sphere_range_m: float = 1.5
    sphere_elevation_m: float = 0.0
    stand_radius_m: float = 0.015
    floor_below_sphere_m: float = 0.28
    roi_half_width_m: float = 0.3
    stray_fraction: float = 0.01
    pass_margin_deg: float = 1.0
    pass_gap_s: float = 2.0
    t_start_s: float = 1.4e9
    site_lat_lon_h: tuple[float, float, float] = (48.42, -4.47, 30.0)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in (
            "latency_s",
            "baud",
            "profile_rate_hz",
            "angular_step_deg",
            "range_noise_m",
            "imu_rate_hz",
            "imu_attitude_noise_deg",
            "pass_attitude_error_deg",
            "rate_regulation_noise_rel",
            "levelling_error_arcsec_max",
            "optical_centre_offset_max_m",
            "sphere_radius_m",
            "sphere_range_m",
            "sphere_elevation_m",
            "stand_radius_m",
            "floor_below_sphere_m",
            "roi_half_width_m",
            "stray_fraction",
            "pass_margin_deg",
            "pass_gap_s",
            "t_start_s",
        ):
            set_(self, name, _finite(getattr(self, name), name))
        for name in ("passes", "fifo_bytes", "seed"):
            value = getattr(self, name)
            _check(
                isinstance(value, (int, np.integer)) and not isinstance(value, bool),
                f"{name} must be a whole number, got {value!r}",
            )
            set_(self, name, int(value))
        _check(self.passes >= 1, f"passes must be at least 1, got {self.passes}")
        _check(self.fifo_bytes >= 0, f"fifo_bytes must be >= 0, got {self.fifo_bytes}")
        _check(self.seed >= 0, f"seed must be >= 0, got {self.seed}")
        rates = tuple(_finite(r, "rates_deg_s") for r in self.rates_deg_s)
        _check(len(rates) > 0, "rates_deg_s is empty; give at least one rate (deg/s)")
        for r in rates:
            _check(
                r > 0.0,
                f"rates_deg_s holds {r:g}; give rate magnitudes > 0 deg/s (each rate is "
                "simulated in both directions)",
            )
        set_(self, "rates_deg_s", rates)
        bore = tuple(_finite(v, "boresight_rpy_deg") for v in self.boresight_rpy_deg)
        _check(len(bore) == 3, f"boresight_rpy_deg needs 3 angles, got {len(bore)}")
        set_(self, "boresight_rpy_deg", bore)
        site = tuple(_finite(v, "site_lat_lon_h") for v in self.site_lat_lon_h)
        _check(len(site) == 3 and abs(site[0]) <= 90.0, "site_lat_lon_h must be (lat, lon, h)")
        set_(self, "site_lat_lon_h", site)
        positive = (
            "baud",
            "profile_rate_hz",
            "angular_step_deg",
            "imu_rate_hz",
            "sphere_radius_m",
            "stand_radius_m",
            "roi_half_width_m",
        )
        for name in positive:
            _check(getattr(self, name) > 0.0, f"{name} must be > 0, got {getattr(self, name)}")
        non_negative = (
            "range_noise_m",
            "imu_attitude_noise_deg",
            "pass_attitude_error_deg",
            "rate_regulation_noise_rel",
            "levelling_error_arcsec_max",
            "optical_centre_offset_max_m",
            "stray_fraction",
            "pass_margin_deg",
        )
        for name in non_negative:
            _check(getattr(self, name) >= 0.0, f"{name} must be >= 0, got {getattr(self, name)}")
        _check(self.angular_step_deg <= 10.0, "angular_step_deg must be <= 10 deg")
        _check(self.stray_fraction <= 0.5, "stray_fraction must be <= 0.5")
        _check(self.rate_regulation_noise_rel < 0.1, "rate_regulation_noise_rel must be < 0.1")
        _check(
            self.stand_radius_m < self.sphere_radius_m,
            "stand_radius_m must be smaller than sphere_radius_m",
        )
        _check(
            self.floor_below_sphere_m > self.sphere_radius_m,
            "floor_below_sphere_m must exceed sphere_radius_m (the sphere stands above it)",
        )
        _check(
            self.roi_half_width_m > self.sphere_radius_m,
            "roi_half_width_m must exceed sphere_radius_m so the box holds the sphere",
        )
        _check(
            self.sphere_range_m > self.roi_half_width_m * math.sqrt(3.0) + 0.05,
            "sphere_range_m must put the export box well clear of the scanner "
            f"(> {self.roi_half_width_m * math.sqrt(3.0) + 0.05:.3f} m)",
        )
        _check(
            abs(self.sphere_elevation_m) < self.sphere_range_m,
            "sphere_elevation_m must be smaller than sphere_range_m",
        )
        _check(self.pass_gap_s >= 0.5, f"pass_gap_s must be >= 0.5 s, got {self.pass_gap_s}")
        _check(abs(self.latency_s) < 0.1, f"latency_s must be within +-0.1 s, got {self.latency_s}")
        self._check_rates_usable()

    def _check_rates_usable(self) -> None:
        """Refuse a rate at which a pass can hold too few sphere returns to be used."""
        limit = self.max_rate_deg_s
        for r in self.rates_deg_s:
            _check(
                r <= limit,
                f"rates_deg_s holds {r:g}: {too_fast_text(r, limit, self.profile_rate_hz)}",
            )

    @property
    def max_rate_deg_s(self) -> float:
        """Largest usable table rate of this scanner and sphere (deg/s, `max_usable_rate_deg_s`)."""
        return max_usable_rate_deg_s(
            profile_rate_hz=self.profile_rate_hz,
            angular_step_deg=self.angular_step_deg,
            sphere_radius_m=self.sphere_radius_m,
            sphere_range_m=self.sphere_range_m,
            sphere_elevation_m=self.sphere_elevation_m,
        )

    @property
    def fifo_delay_s(self) -> float:
        """Delay added by the receive FIFO, ``fifo_bytes * 10 / baud`` (s)."""
        return serial_transmission_time_s(self.fifo_bytes, self.baud)

    @property
    def total_latency_s(self) -> float:
        """Total latency tau = IMU latency + FIFO delay (s)."""
        return self.latency_s + self.fifo_delay_s

    @property
    def signed_rates_deg_s(self) -> tuple[float, ...]:
        """Signed rate of every pass, in simulation order (deg/s)."""
        return tuple(s * r for r in self.rates_deg_s for _ in range(self.passes) for s in (1, -1))
