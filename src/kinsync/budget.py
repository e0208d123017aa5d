"""Error budgets: latency, serial FIFO delay and profile-clock period (SPEC section 3).

Latency -> point error uses exact ray-plane geometry.

A latency tau under an angular rate vector omega is an attitude error
``epsilon = omega * tau`` (a rotation vector). The beam really points along
``Rot(+-epsilon) d`` while the georeferencing assumes ``d``; the true beam meets the
surface at range ``r_true`` and that range is placed along the assumed beam. Both signs
of epsilon are evaluated and the worse is reported. No small-angle linearisation is
made; the first-order values are reported beside the exact ones for comparison.

References
----------
Seube, N., Picard, A., Rondeau, M., "A simple method to recover the latency time of
tactical grade IMU systems", ISPRS J. Photogramm. Remote Sens. 74 (2012) 85-89.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from kinsync._typing import ArrayLike, FloatArray
from kinsync._validate import finite_number, finite_vector
from kinsync.errors import InputError

__all__ = [
    "BeamErrorBudget",
    "PeriodErrorBudget",
    "Scenario",
    "beach_scenario",
    "bits_per_serial_byte",
    "cross_track_scenario",
    "latency_beam_error",
    "period_error_budget",
    "rolling_table_scenario",
    "serial_transmission_time_s",
]

Parity = Literal["none", "even", "odd", "mark", "space"]

_GRAZING_COS = 1e-9
"""A true beam closer than this (cosine to the surface plane, ~2e-7 deg) grazes it."""
_MAX_ATTITUDE_ERROR_DEG = 180.0
"""An attitude error |omega tau| from here on is refused: it would wrap to a smaller one."""


def _unit3(vec: ArrayLike, name: str) -> FloatArray:
    v = finite_vector(vec, 3, name)
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        msg = f"{name}: the zero vector has no direction"
        raise InputError(msg)
    return v / norm


@dataclass(frozen=True)
class Scenario:
    """Geometry of one beam hitting a plane, in a local NED frame at the scanner.

    Attributes
    ----------
    name : str
        Label for reports.
    range_m : float
        Slant range along the assumed beam to the surface (m), > 0.
    beam_ned : tuple of 3 float
        Unit direction of the assumed beam, NED.
    normal_ned : tuple of 3 float
        Unit normal of the surface plane, NED.
    rate_ned_rad_s : tuple of 3 float
        Angular rate vector of the platform, NED (rad/s).
    vel_ned_m_s : tuple of 3 float
        Velocity of the platform, NED (m/s); default at rest. A latency tau then also
        misplaces the scanner by ``vel * tau`` (the position of the wrong instant).
    """

    name: str
    range_m: float
    beam_ned: tuple[float, float, float]
    normal_ned: tuple[float, float, float]
    rate_ned_rad_s: tuple[float, float, float]
    vel_ned_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        rng = finite_number(self.range_m, "range_m")
        if rng <= 0.0:
            msg = f"range_m: the slant range must be positive, got {self.range_m!r}"
            raise InputError(msg)
        beam = _unit3(self.beam_ned, "beam_ned")
        normal = _unit3(self.normal_ned, "normal_ned")
        if abs(float(beam @ normal)) < 1e-9:
            msg = "beam_ned is parallel to the surface: it never meets it"
            raise InputError(msg)
        rate = np.asarray(self.rate_ned_rad_s, dtype=np.float64)
        if rate.shape != (3,) or not np.all(np.isfinite(rate)):
            msg = f"rate_ned_rad_s: expected 3 finite numbers, got {self.rate_ned_rad_s!r}"
            raise InputError(msg)
        object.__setattr__(self, "range_m", rng)
        object.__setattr__(self, "beam_ned", tuple(float(x) for x in beam))
        object.__setattr__(self, "normal_ned", tuple(float(x) for x in normal))
        object.__setattr__(self, "rate_ned_rad_s", tuple(float(x) for x in rate))
        vel = finite_vector(self.vel_ned_m_s, 3, "vel_ned_m_s")
        object.__setattr__(self, "vel_ned_m_s", tuple(float(x) for x in vel))


def cross_track_scenario(
    range_m: float = 50.0,
    slope_deg: float = 10.0,
    rate_deg_s: float = 10.0,
    beam_deg: float = 0.0,
    speed_m_s: float = 0.0,
) -> Scenario:
    """A cross-track beam onto a sloping surface under a roll rate, at a speed.

    The platform heads North at ``speed_m_s``; the beam points East, ``beam_deg`` below
    horizontal (0: horizontal, as `beach_scenario`; 90: straight down, as an airborne
    scanner at nadir), and meets a surface rising towards the East at ``slope_deg``; the
    roll rate turns about North.

    Parameters
    ----------
    range_m : float
        Slant range to the surface along the beam (m), > 0.
    slope_deg : float
        Surface slope (deg), in [0, 90).
    rate_deg_s : float
        Roll rate (deg/s).
    beam_deg : float
        Beam depression below horizontal (deg), in [0, 90]; default 0.
    speed_m_s : float
        Speed over ground, along North (m/s), >= 0; default 0.

    Returns
    -------
    Scenario

    Raises
    ------
    InputError
        A value not a finite number or out of its range, or a beam that does not meet
        the surface (horizontal onto a flat surface).
    """
    slope = finite_number(slope_deg, "slope_deg")
    beam = finite_number(beam_deg, "beam_deg")
    speed = finite_number(speed_m_s, "speed_m_s")
    if not 0.0 <= beam <= 90.0:
        msg = f"beam_deg: the beam's depression below horizontal must lie in [0, 90], got {beam}"
        raise InputError(msg)
    if not 0.0 <= slope < 90.0:
        msg = f"slope_deg: must lie in [0, 90), got {slope}"
        raise InputError(msg)
    if beam + slope <= 0.0:
        msg = (
            "slope_deg 0: a horizontal beam never meets a flat surface; give a slope "
            "(--slope-deg, a beach) or a beam below horizontal (--beam-deg 90: nadir)"
        )
        raise InputError(msg)
    if speed < 0.0:
        msg = f"speed_m_s: must be >= 0, got {speed}"
        raise InputError(msg)
    a, b = math.radians(slope), math.radians(beam)
    return Scenario(
        name=(
            f"beam {beam:g} deg below horizontal onto a {slope:g} deg slope at {range_m:g} m, "
            f"roll {rate_deg_s:g} deg/s, {speed:g} m/s"
        ),
        range_m=range_m,
        beam_ned=(0.0, math.cos(b), math.sin(b)),
        normal_ned=(0.0, -math.sin(a), -math.cos(a)),
        rate_ned_rad_s=(math.radians(finite_number(rate_deg_s, "rate_deg_s")), 0.0, 0.0),
        vel_ned_m_s=(speed, 0.0, 0.0),
    )


def beach_scenario(
    range_m: float = 50.0, slope_deg: float = 10.0, rate_deg_s: float = 10.0
) -> Scenario:
    """SPEC section 3 reference: a horizontal beam onto a sloping beach under a roll rate.

    The vessel heads North; the beam points East (horizontal, cross-track) and meets a
    beach rising towards the East at ``slope_deg``; the roll rate turns about North.

    Parameters
    ----------
    range_m : float
        Slant range to the beach along the beam (m).
    slope_deg : float
        Beach slope (deg), in (0, 90).
    rate_deg_s : float
        Roll rate (deg/s).
    """
    slope = finite_number(slope_deg, "slope_deg")
    if not 0.0 < slope < 90.0:
        msg = (
            "slope_deg: the beach scenario needs a slope in (0, 90), got "
            f"{slope}: a horizontal beam never meets a flat beach, and a vertical wall "
            "(90 deg) has no vertical error"
        )
        raise InputError(msg)
    return replace(
        cross_track_scenario(range_m, slope, rate_deg_s),
        name=f"beach {slope:g} deg at {range_m:g} m, roll {rate_deg_s:g} deg/s",
    )


def rolling_table_scenario(
    elevation_deg: float,
    range_m: float = 25.0,
    roll_amplitude_deg: float = 6.0,
    roll_frequency_hz: float = 1.0,
    yaw_rate_deg_s: float = 1.0,
) -> Scenario:
    """SPEC section 3 second scenario: a table rolling +-6 deg at 1 Hz while turning 1 deg/s.

    One beam of a sector scanned in the cross-track vertical plane (pointing East, at
    ``elevation_deg`` above horizontal) onto a vertical wall facing the scanner at
    ``range_m`` horizontal distance; the rate vector is the peak roll rate
    ``2 pi f A`` about North plus the yaw rate about Down.

    Parameters
    ----------
    elevation_deg : float
        Beam elevation above horizontal (deg), in (-90, 90); positive points up.
    range_m : float
        Horizontal distance from the scanner to the wall (m), > 0; the slant range
        along the beam is ``range_m / cos(elevation)``.
    roll_amplitude_deg : float
        Roll amplitude A of the table (deg); default 6.
    roll_frequency_hz : float
        Roll frequency f (Hz); default 1.
    yaw_rate_deg_s : float
        Turn rate about Down (deg/s); default 1.

    Returns
    -------
    Scenario
        In the local NED frame at the scanner: beam East at the elevation, wall normal
        towards the scanner (West), rate ``(2 pi f A, 0, yaw rate)`` (rad/s).

    Raises
    ------
    InputError
        ``elevation_deg`` or ``range_m`` not a finite number, an elevation outside
        (-90, 90), a range not positive, or a roll or yaw value that gives a
        non-finite rate.
    """
    el = math.radians(finite_number(elevation_deg, "elevation_deg"))
    if abs(el) >= math.pi / 2:
        msg = f"elevation_deg: must lie in (-90, 90), got {elevation_deg}"
        raise InputError(msg)
    roll_rate = 2.0 * math.pi * roll_frequency_hz * math.radians(roll_amplitude_deg)
    return Scenario(
        name=f"rolling table, beam at {elevation_deg:+g} deg",
        range_m=finite_number(range_m, "range_m") / math.cos(el),
        beam_ned=(0.0, math.cos(el), -math.sin(el)),
        normal_ned=(0.0, -1.0, 0.0),
        rate_ned_rad_s=(roll_rate, 0.0, math.radians(yaw_rate_deg_s)),
    )


@dataclass(frozen=True)
class BeamErrorBudget:
    """Point error caused by a latency in one scenario (worse of the two signs of epsilon).

    Attributes
    ----------
    latency_s : float
        Latency evaluated (s).
    attitude_error_rad : float
        ``|omega| * |tau|`` (rad).
    vertical_error_m : float or None
        Height of the georeferenced point above (+) or below (-) the true surface at its
        horizontal position; None for a vertical surface. Sign of the worse case.
    horizontal_error_m : float
        Horizontal distance between where the assumed and the true beams meet the
        surface (m), worse case.
    point_error_m : float
        3-D distance between the georeferenced point and the point really hit (m).
    point_horizontal_error_m, point_vertical_error_m : float
        Horizontal distance and height (up positive) of the georeferenced point from the
        point really hit (m), in the case of ``point_error_m``: what a check against a
        surveyed point shows (``horizontal_error_m`` and ``vertical_error_m`` are taken
        on the surface instead).
    vertical_error_linear_m, horizontal_error_linear_m : float or None
        First-order (small-angle) values of the same quantities, for comparison.
    range_true_m : float
        Range to the surface along the true beam, worse case for ``point_error_m`` (m).
    position_error_m : float
        ``|vel| * |tau|``: how far the scanner is misplaced (m), in every case above.
    """

    latency_s: float
    attitude_error_rad: float
    vertical_error_m: float | None
    horizontal_error_m: float
    point_error_m: float
    vertical_error_linear_m: float | None
    horizontal_error_linear_m: float
    range_true_m: float
    point_horizontal_error_m: float = 0.0
    point_vertical_error_m: float = 0.0
    position_error_m: float = 0.0


def _errors_for_rotation(
    scenario: Scenario, rotvec_ned: FloatArray, shift_ned_m: FloatArray
) -> tuple[float | None, float, float, float, FloatArray]:
    """Vertical, horizontal, point error, true range and the point's error vector (NED).

    For one attitude error ``rotvec_ned`` and scanner position error ``shift_ned_m``.
    """
    d = np.asarray(scenario.beam_ned)
    n = np.asarray(scenario.normal_ned)
    p0 = scenario.range_m * d
    from scipy.spatial.transform import Rotation  # noqa: PLC0415 - CLI start-up

    d_true = Rotation.from_rotvec(rotvec_ned).apply(d)
    denom = float(n @ d_true)
    # An error equal to the grazing angle leaves cos ~1e-17 after the rotation, not 0,
    # and a "range" of 1e17 m: a true beam within _GRAZING_COS of the surface misses it.
    toward = math.copysign(1.0, float(n @ d))
    grazing = denom * toward <= _GRAZING_COS
    r_true = math.inf if grazing else float(n @ p0) / denom
    if not (math.isfinite(r_true) and r_true > 0.0):
        eps_deg = math.degrees(float(np.linalg.norm(rotvec_ned)))
        msg = (
            f"attitude error {eps_deg:.4g} deg reaches or exceeds the grazing angle: the "
            "true beam runs along or misses the surface; reduce the latency or rate, or "
            "steepen the beam"
        )
        raise InputError(msg)
    hit_true = r_true * d_true
    placed = shift_ned_m + r_true * d
    # the assumed beam, from the misplaced scanner, meets the surface here
    hit_assumed = shift_ned_m + (float(n @ (p0 - shift_ned_m)) / float(n @ d)) * d
    horizontal = float(np.hypot(*(hit_true - hit_assumed)[:2]))
    point = float(np.linalg.norm(placed - hit_true))
    vertical: float | None = None
    if abs(n[2]) > 1e-12:
        ground_down = p0[2] - (n[0] * (placed[0] - p0[0]) + n[1] * (placed[1] - p0[1])) / n[2]
        vertical = float(ground_down - placed[2])  # up positive: -(placed_down - ground_down)
    return vertical, horizontal, point, r_true, placed - hit_true


def _linear_errors(
    scenario: Scenario, rotvec_ned: FloatArray, shift_ned_m: FloatArray
) -> tuple[float | None, float]:
    """First-order vertical and horizontal errors of one small attitude error.

    The true beam turns by ``delta = eps x d``; to first order it meets the plane at
    ``p0 + R (delta - k d)`` with ``k = n . delta / n . d``, and the point placed along
    ``d`` at the true range sits ``R (n . delta) / n_down`` above the surface. A scanner
    misplaced by ``s`` moves the assumed beam's meeting point by ``s - (n . s / n . d) d``
    and the placed point's height by ``-(n . s) / n_down``. Evaluated in closed form: a
    scaled-down rotation underflowed for a tiny latency (1e-9 ms gave 0.0 for an exact
    -8.7e-12 m).
    """
    d = np.asarray(scenario.beam_ned)
    n = np.asarray(scenario.normal_ned)
    delta = np.cross(rotvec_ned, d)
    k = float(n @ delta) / float(n @ d)
    moved = shift_ned_m - (float(n @ shift_ned_m) / float(n @ d)) * d
    horizontal = float(np.hypot(*(scenario.range_m * (delta - k * d) - moved)[:2]))
    vertical = (
        None
        if abs(n[2]) <= 1e-12
        else (scenario.range_m * float(n @ delta) - float(n @ shift_ned_m)) / float(n[2])
    )
    return vertical, horizontal


def latency_beam_error(scenario: Scenario, latency_s: float) -> BeamErrorBudget:
    """Exact point error of a latency under a scenario's angular rate.

    Parameters
    ----------
    scenario : Scenario
        Beam, surface and rate geometry.
    latency_s : float
        Latency tau (s); its sign does not matter, both signs of epsilon are evaluated.

    Returns
    -------
    BeamErrorBudget
        The worse of the two signs for each quantity, with first-order values.

    Raises
    ------
    InputError
        A non-finite latency, an attitude error ``|omega tau|`` of half a turn or more
        (it would wrap to a smaller one), or one large enough that the true beam misses
        the surface.
    """
    tau = finite_number(latency_s, "latency_s")
    eps = np.asarray(scenario.rate_ned_rad_s) * tau
    eps_deg = math.degrees(float(np.linalg.norm(eps)))
    if eps_deg >= _MAX_ATTITUDE_ERROR_DEG:
        # Beyond half a turn the rotation reads as a smaller one of the other sign (a
        # full turn as none at all): the budget would be silently wrong.
        msg = (
            f"attitude error {eps_deg:.4g} deg (rate x latency) is half a turn or more; a "
            "latency budget holds for errors well below that: check the latency (ms) "
            "and the rate (deg/s)"
        )
        raise InputError(msg)
    # the record of the wrong instant: its attitude and its position, both tau away
    shift = np.asarray(scenario.vel_ned_m_s) * tau
    cases = [_errors_for_rotation(scenario, sign * eps, sign * shift) for sign in (1.0, -1.0)]
    small = [_linear_errors(scenario, sign * eps, sign * shift) for sign in (1.0, -1.0)]

    def worst_index(values: list[float | None]) -> int | None:
        real = [(abs(v), i) for i, v in enumerate(values) if v is not None]
        return max(real)[1] if real else None

    iv = worst_index([c[0] for c in cases])
    ih = int(np.argmax([c[1] for c in cases]))
    ip = int(np.argmax([c[2] for c in cases]))
    vertical = None if iv is None else cases[iv][0]
    vertical_lin = None if iv is None else small[iv][0]
    return BeamErrorBudget(
        latency_s=tau,
        attitude_error_rad=float(np.linalg.norm(eps)),
        vertical_error_m=vertical,
        horizontal_error_m=cases[ih][1],
        point_error_m=cases[ip][2],
        vertical_error_linear_m=vertical_lin,
        horizontal_error_linear_m=small[ih][1],
        range_true_m=cases[ip][3],
        point_horizontal_error_m=float(np.hypot(*cases[ip][4][:2])),
        point_vertical_error_m=-float(cases[ip][4][2]),
        position_error_m=float(np.linalg.norm(shift)),
    )


_PARITY_BITS = {"none": 0, "even": 1, "odd": 1, "mark": 1, "space": 1}


def bits_per_serial_byte(
    data_bits: int = 8, parity: Parity | str = "none", stop_bits: float = 1.0
) -> float:
    """Bits on the wire per byte of an asynchronous serial frame.

    One start bit + ``data_bits`` + one parity bit (unless ``parity == "none"``) +
    ``stop_bits`` (1, 1.5 or 2).

    Parameters
    ----------
    data_bits : int
        Data bits per byte: 5, 6, 7 or 8 (default 8).
    parity : {"none", "even", "odd", "mark", "space"}
        Parity bit; "none" (the default) sends none.
    stop_bits : float
        Stop bits: 1 (the default), 1.5 or 2.

    Returns
    -------
    float
        Bits per byte on the wire (10.0 for 8N1).

    Raises
    ------
    InputError
        A data-bit count, parity or stop-bit count not among those above.
    """
    if data_bits not in (5, 6, 7, 8):
        msg = f"data bits must be 5, 6, 7 or 8, got {data_bits!r}"
        raise InputError(msg)
    if parity not in _PARITY_BITS:
        msg = f"parity must be one of {', '.join(_PARITY_BITS)}, got {parity!r}"
        raise InputError(msg)
    if stop_bits not in (1, 1.5, 2):
        msg = f"stop bits must be 1, 1.5 or 2, got {stop_bits!r}"
        raise InputError(msg)
    return 1.0 + data_bits + _PARITY_BITS[parity] + float(stop_bits)


def serial_transmission_time_s(
    n_bytes: int,
    baud: float,
    data_bits: int = 8,
    parity: Parity | str = "none",
    stop_bits: float = 1.0,
) -> float:
    """Time to send ``n_bytes`` over an asynchronous serial line (s).

    This is both a message's transmission time and the delay a receive FIFO of
    ``n_bytes`` adds before the acquisition software sees the data:
    ``n_bytes * bits_per_byte / baud``.

    Parameters
    ----------
    n_bytes : int
        Bytes (message length or FIFO depth), >= 0.
    baud : float
        Line rate (bit/s), > 0.
    data_bits, parity, stop_bits
        Frame format (default 8N1).
    """
    if isinstance(n_bytes, bool) or int(n_bytes) != n_bytes or n_bytes < 0:
        msg = f"bytes must be a non-negative whole number, got {n_bytes!r}"
        raise InputError(msg)
    rate = finite_number(baud, "baud")
    if rate <= 0.0:
        msg = f"baud must be positive, got {baud!r}"
        raise InputError(msg)
    return int(n_bytes) * bits_per_serial_byte(data_bits, parity, stop_bits) / rate


@dataclass(frozen=True)
class PeriodErrorBudget:
    """Error accumulated by a profile-clock period error.

    Attributes
    ----------
    time_error_s : float
        ``N * dT`` after N profiles (s).
    position_error_m : float
        ``v * N * dT`` at speed v (m).
    """

    time_error_s: float
    position_error_m: float


def period_error_budget(
    n_profiles: int, period_error_s: float, speed_m_s: float
) -> PeriodErrorBudget:
    """Time and along-track position error after ``n_profiles`` with a period error.

    Parameters
    ----------
    n_profiles : int
        Profiles counted since the clock was fixed, >= 0.
    period_error_s : float
        Error of the mirror period (s).
    speed_m_s : float
        Platform speed (m/s), >= 0.
    """
    if isinstance(n_profiles, bool) or int(n_profiles) != n_profiles or n_profiles < 0:
        msg = f"profiles must be a non-negative whole number, got {n_profiles!r}"
        raise InputError(msg)
    d_period = finite_number(period_error_s, "period_error_s")
    speed = finite_number(speed_m_s, "speed_m_s")
    if speed < 0.0:
        msg = f"speed_m_s must be >= 0, got {speed_m_s!r}"
        raise InputError(msg)
    time_error = int(n_profiles) * d_period
    return PeriodErrorBudget(time_error_s=time_error, position_error_m=speed * abs(time_error))
