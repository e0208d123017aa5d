"""Route geometry and smooth kinematics for the drive simulator (`kinsync.sim.drive`).

A `Route` is a sequence of segments — straight runs, turns, stops — driven at a cruise
speed. Everything is smooth so that simulated IMU data are realistic:

- **Speed.** Between standstills (start, each `Stop`, end) the horizontal speed rises
  from 0 to the cruise speed and falls back with the quintic smooth step
  ``S(x) = 10x^3 - 15x^4 + 6x^5``: ``v = V S(t / T_a)`` with ``T_a = 1.875 V / a_max``
  (``a_max`` is the peak longitudinal acceleration); speed, acceleration and jerk are
  continuous. A run too short to reach the cruise speed peaks at
  ``sqrt(D a_max / 1.875)``.
- **Curvature.** A turn of angle ``theta`` and radius ``R`` ramps its curvature from 0
  to ``1/R`` over ``L_t = f R |theta|`` of path (the same smooth step in arc length, a
  clothoid-like transition), holds it over ``R |theta| - L_t`` and ramps it back
  (``f = transition_fraction``); the heading turns by exactly ``theta`` over a path of
  ``R |theta| (1 + f)``. Curvature, hence yaw rate and lateral acceleration, is
  continuous everywhere; ``R`` is the tightest radius of the turn.
- **Attitude.** Yaw follows the path heading (no side slip); pitch follows the slope of
  the optional height undulation ``h(s) = A sin(2 pi s / lambda)`` (``s``: horizontal
  path length), plus optional roll/pitch oscillations ``A sin(2 pi t / P)`` of a vessel
  (these run also at standstill, as waves do).

Angles: yaw clockwise from North seen from above (positive turn = right), DIN 9300
roll/pitch/yaw; the speed is the horizontal speed over ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from kinsync._typing import FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError

__all__ = [
    "DEFAULT_TRANSITION_FRACTION",
    "KinematicState",
    "Route",
    "RouteKinematics",
    "Segment",
    "Stop",
    "Straight",
    "Turn",
    "VehicleMotion",
    "figure_eight_route",
    "oval_route",
    "survey_lines_route",
    "turn_chord_m",
]

DEFAULT_TRANSITION_FRACTION = 0.25
"""Default curvature ramp length of a turn end, as a fraction of ``R |theta|``."""
_ACC_PHASE_FACTOR = 1.875
"""Peak of the smooth step's derivative, 30/16: ``a_max = 1.875 V / T_a``."""
_GL_NODES = 16
"""Gauss–Legendre nodes per piece for the turn chord quadrature."""


def _smooth(x: FloatArray) -> FloatArray:
    """Quintic smooth step S(x) on [0, 1]: S(0) = 0, S(1) = 1, S' = S'' = 0 at both ends."""
    out: FloatArray = x * x * x * (10.0 + x * (-15.0 + 6.0 * x))
    return out


def _smooth_rate(x: FloatArray) -> FloatArray:
    """Derivative S'(x) = 30 x^2 (1 - x)^2."""
    out: FloatArray = 30.0 * x * x * (1.0 - x) ** 2
    return out


def _smooth_integral(x: FloatArray) -> FloatArray:
    """Integral of S from 0 to x: x^4 (5/2 - 3x + x^2); 1/2 at x = 1."""
    out: FloatArray = x**4 * (2.5 + x * (-3.0 + x))
    return out


def _err(message: str) -> InputError:
    return InputError(f"route: {message}")


@dataclass(frozen=True)
class Straight:
    """Straight run of ``length_m`` (m, > 0) of horizontal path."""

    length_m: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "length_m", positive_number(self.length_m, "Straight length_m"))


@dataclass(frozen=True)
class Turn:
    """Turn by ``angle_deg`` (+ = right, clockwise seen from above; not 0) on ``radius_m``.

    ``radius_m`` (> 0) is the tightest radius, held between the curvature transitions.
    """

    angle_deg: float
    radius_m: float

    def __post_init__(self) -> None:
        angle = finite_number(self.angle_deg, "Turn angle_deg")
        if angle == 0.0:
            msg = "Turn angle_deg must not be 0; give a signed angle (+ = right)"
            raise InputError(msg)
        object.__setattr__(self, "angle_deg", angle)
        object.__setattr__(self, "radius_m", positive_number(self.radius_m, "Turn radius_m"))


@dataclass(frozen=True)
class Stop:
    """Come to a standstill, wait ``duration_s`` (s, > 0), drive on."""

    duration_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "duration_s", positive_number(self.duration_s, "Stop duration_s"))


Segment = Straight | Turn | Stop
"""One element of a route."""


@dataclass(frozen=True)
class Route:
    """A drive: segments, cruise speed and standstills (see the module docstring).

    Attributes
    ----------
    segments : tuple of Straight, Turn, Stop
        Driven in order; at least one `Straight` or `Turn`.
    speed_m_s : float
        Cruise horizontal speed (m/s, > 0).
    max_acc_m_s2 : float
        Peak longitudinal acceleration of the speed ramps (m/s^2, > 0).
    static_s : float
        Standstill before the drive (s, >= 0), e.g. for static levelling.
    end_static_s : float
        Standstill after the drive (s, >= 0).
    transition_fraction : float
        Curvature ramp length of each turn end as a fraction of ``R |theta|`` (0, 1].
    """

    segments: tuple[Segment, ...]
    speed_m_s: float = 2.0
    max_acc_m_s2: float = 0.5
    static_s: float = 0.0
    end_static_s: float = 0.0
    transition_fraction: float = DEFAULT_TRANSITION_FRACTION

    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        for i, seg in enumerate(segs):
            if not isinstance(seg, Straight | Turn | Stop):
                msg = f"segment {i} is {seg!r}; expected Straight, Turn or Stop"
                raise _err(msg)
        if not any(isinstance(s, Straight | Turn) for s in segs):
            msg = "no Straight or Turn segment: nothing to drive"
            raise _err(msg)
        object.__setattr__(self, "segments", segs)
        object.__setattr__(self, "speed_m_s", positive_number(self.speed_m_s, "route speed_m_s"))
        object.__setattr__(
            self, "max_acc_m_s2", positive_number(self.max_acc_m_s2, "route max_acc_m_s2")
        )
        for name in ("static_s", "end_static_s"):
            value = finite_number(getattr(self, name), f"route {name}")
            if value < 0.0:
                msg = f"{name} must be >= 0 s, got {value}"
                raise _err(msg)
            object.__setattr__(self, name, value)
        f = finite_number(self.transition_fraction, "route transition_fraction")
        if not 0.0 < f <= 1.0:
            msg = f"transition_fraction must be in (0, 1], got {f}"
            raise _err(msg)
        object.__setattr__(self, "transition_fraction", f)

    @property
    def length_m(self) -> float:
        """Horizontal path length (m)."""
        return float(sum(_segment_length_m(s, self.transition_fraction) for s in self.segments))

    @property
    def duration_s(self) -> float:
        """Time from the start of the initial standstill to the end of the final one (s)."""
        return RouteKinematics(self).duration_s


def _segment_length_m(seg: Segment, fraction: float) -> float:
    if isinstance(seg, Straight):
        return seg.length_m
    if isinstance(seg, Turn):
        return seg.radius_m * abs(math.radians(seg.angle_deg)) * (1.0 + fraction)
    return 0.0


@dataclass(frozen=True)
class VehicleMotion:
    """Attitude and height motion added to a route (defaults: none; heading north).

    Attributes
    ----------
    initial_yaw_deg : float
        Heading at the start of the route (deg, clockwise from North).
    roll_amplitude_deg, roll_period_s : float
        Roll oscillation ``A sin(2 pi t / P)`` (deg, s); a vessel in waves.
    pitch_amplitude_deg, pitch_period_s : float
        Pitch oscillation ``A sin(2 pi t / P + pi / 3)`` (deg, s).
    undulation_amplitude_m, undulation_wavelength_m : float
        Height ``A sin(2 pi s / lambda)`` along the horizontal path length ``s`` (m, m);
        the pitch follows the slope.
    """

    initial_yaw_deg: float = 0.0
    roll_amplitude_deg: float = 0.0
    roll_period_s: float = 6.0
    pitch_amplitude_deg: float = 0.0
    pitch_period_s: float = 8.0
    undulation_amplitude_m: float = 0.0
    undulation_wavelength_m: float = 50.0

    def __post_init__(self) -> None:
        for name in (
            "initial_yaw_deg",
            "roll_amplitude_deg",
            "pitch_amplitude_deg",
            "undulation_amplitude_m",
        ):
            object.__setattr__(self, name, finite_number(getattr(self, name), name))
        for name in ("roll_period_s", "pitch_period_s", "undulation_wavelength_m"):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        if abs(self.roll_amplitude_deg) >= 60.0 or abs(self.pitch_amplitude_deg) >= 30.0:
            msg = (
                f"roll amplitude {self.roll_amplitude_deg} deg / pitch amplitude "
                f"{self.pitch_amplitude_deg} deg: keep them below 60 / 30 deg"
            )
            raise InputError(msg)
        max_slope = 2.0 * math.pi * abs(self.undulation_amplitude_m) / self.undulation_wavelength_m
        if max_slope > 0.5:
            msg = (
                f"height undulation of {self.undulation_amplitude_m} m over "
                f"{self.undulation_wavelength_m} m gives slopes up to {max_slope:.2f}; "
                "keep 2 pi A / lambda <= 0.5"
            )
            raise InputError(msg)


@dataclass(frozen=True, eq=False)
class KinematicState:
    """Exact kinematic state of a route at given times (route time: 0 = start).

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Route times (s).
    s_m, speed_m_s, acc_m_s2 : ndarray, shape (n,)
        Horizontal path length, its first and second time derivatives.
    rpy_rad, rpy_rate_rad_s : ndarray, shape (n, 3)
        DIN 9300 roll, pitch, yaw (body -> NED) and their time derivatives.
    height_m, height_rate_m_s : ndarray, shape (n,)
        Height above the start height and its rate (m, m/s).
    vel_ned_m_s, acc_ned_m_s2 : ndarray, shape (n, 3)
        Velocity over the Earth in NED and its time derivative (local-level components).
    """

    t_s: FloatArray
    s_m: FloatArray
    speed_m_s: FloatArray
    acc_m_s2: FloatArray
    rpy_rad: FloatArray
    rpy_rate_rad_s: FloatArray
    height_m: FloatArray
    height_rate_m_s: FloatArray
    vel_ned_m_s: FloatArray
    acc_ned_m_s2: FloatArray

    def rate_nb_body_rad_s(self) -> FloatArray:
        """Angular rate of the body w.r.t. NED in the body frame, shape (n, 3) (rad/s).

        From the DIN 9300 Euler rates: ``(phi' - psi' sin(theta),
        theta' cos(phi) + psi' sin(phi) cos(theta),
        -theta' sin(phi) + psi' cos(phi) cos(theta))``.
        """
        roll, pitch = self.rpy_rad[:, 0], self.rpy_rad[:, 1]
        dr, dp, dy = self.rpy_rate_rad_s.T
        cr, sr = np.cos(roll), np.sin(roll)
        cp, sp = np.cos(pitch), np.sin(pitch)
        return np.column_stack([dr - dy * sp, dp * cr + dy * sr * cp, -dp * sr + dy * cr * cp])


@dataclass(frozen=True)
class _Phases:
    """Time line of standstills and motion blocks (route time)."""

    start_s: FloatArray  # (P,) phase start times
    duration_s: FloatArray  # (P,)
    moving: tuple[bool, ...]
    s_start_m: FloatArray  # path length at the phase start
    length_m: FloatArray  # path driven in the phase (0 for standstill)
    peak_speed_m_s: FloatArray  # 0 for standstill
    ramp_s: FloatArray  # T_a (0 for standstill)


@dataclass(frozen=True, eq=False)
class RouteKinematics:
    """Exact, smooth kinematics of a route (evaluate at any time; constant outside).

    Parameters
    ----------
    route : Route
    motion : VehicleMotion, optional
        Attitude oscillations, height undulation and initial heading.
    """

    route: Route
    motion: VehicleMotion = field(default_factory=VehicleMotion)
    _phases: _Phases = field(init=False, repr=False)
    _seg: dict[str, FloatArray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        r = self.route
        f = r.transition_fraction
        s0: list[float] = []
        length: list[float] = []
        psi0: list[float] = []
        kappa: list[float] = []
        ramp: list[float] = []
        theta: list[float] = []
        s_acc, psi_acc = 0.0, 0.0
        for seg in r.segments:
            if isinstance(seg, Stop):
                continue
            s0.append(s_acc)
            psi0.append(psi_acc)
            if isinstance(seg, Straight):
                length.append(seg.length_m)
                kappa.append(0.0)
                ramp.append(0.0)
                theta.append(0.0)
            else:
                th = math.radians(seg.angle_deg)
                arc = seg.radius_m * abs(th)
                length.append(arc * (1.0 + f))
                kappa.append(math.copysign(1.0 / seg.radius_m, th))
                ramp.append(f * arc)
                theta.append(th)
            s_acc += length[-1]
            psi_acc += theta[-1]
        seg_arrays = {
            "s0": np.array(s0),
            "length": np.array(length),
            "psi0": np.array(psi0),
            "kappa": np.array(kappa),
            "ramp": np.array(ramp),
            "theta": np.array(theta),
        }
        object.__setattr__(self, "_seg", seg_arrays)
        object.__setattr__(self, "_phases", self._time_line())

    def _time_line(self) -> _Phases:
        r = self.route
        f = r.transition_fraction
        start: list[float] = []
        dur: list[float] = []
        moving: list[bool] = []
        s_start: list[float] = []
        length: list[float] = []
        peak: list[float] = []
        ramp: list[float] = []
        t, s = 0.0, 0.0

        def add(d: float, move: float) -> None:
            nonlocal t, s
            if move > 0.0:
                v = min(r.speed_m_s, math.sqrt(move * r.max_acc_m_s2 / _ACC_PHASE_FACTOR))
                t_a = _ACC_PHASE_FACTOR * v / r.max_acc_m_s2
                d = 2.0 * t_a + (move - v * t_a) / v
            else:
                v, t_a = 0.0, 0.0
            if d <= 0.0:
                return
            start.append(t)
            dur.append(d)
            moving.append(move > 0.0)
            s_start.append(s)
            length.append(move)
            peak.append(v)
            ramp.append(t_a)
            t += d
            s += move

        add(r.static_s, 0.0)
        block = 0.0
        for seg in r.segments:
            if isinstance(seg, Stop):
                add(0.0, block)
                add(seg.duration_s, 0.0)
                block = 0.0
            else:
                block += _segment_length_m(seg, f)
        add(0.0, block)
        add(r.end_static_s, 0.0)
        return _Phases(
            start_s=np.array(start),
            duration_s=np.array(dur),
            moving=tuple(moving),
            s_start_m=np.array(s_start),
            length_m=np.array(length),
            peak_speed_m_s=np.array(peak),
            ramp_s=np.array(ramp),
        )

    @property
    def duration_s(self) -> float:
        """Route duration, standstills included (s)."""
        p = self._phases
        return float(p.start_s[-1] + p.duration_s[-1])

    @property
    def length_m(self) -> float:
        """Horizontal path length (m)."""
        return float(self._seg["s0"][-1] + self._seg["length"][-1])

    def _along(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Path length, speed and acceleration along the path at route times ``t``."""
        p = self._phases
        s = np.empty_like(t)
        v = np.zeros_like(t)
        a = np.zeros_like(t)
        idx = np.clip(np.searchsorted(p.start_s, t, side="right") - 1, 0, len(p.moving) - 1)
        before = t < 0.0
        after = t >= self.duration_s
        for k, is_moving in enumerate(p.moving):
            m = (idx == k) & ~before & ~after
            if not np.any(m):
                continue
            if not is_moving:
                s[m] = p.s_start_m[k]
                continue
            tau = t[m] - p.start_s[k]
            big_v, t_a, dist, d = p.peak_speed_m_s[k], p.ramp_s[k], p.length_m[k], p.duration_s[k]
            sk = np.empty_like(tau)
            vk = np.full_like(tau, big_v)
            ak = np.zeros_like(tau)
            up = tau < t_a
            down = tau > d - t_a
            mid = ~up & ~down
            x = tau[up] / t_a
            sk[up] = big_v * t_a * _smooth_integral(x)
            vk[up] = big_v * _smooth(x)
            ak[up] = big_v / t_a * _smooth_rate(x)
            sk[mid] = big_v * t_a * 0.5 + big_v * (tau[mid] - t_a)
            x = np.clip((d - tau[down]) / t_a, 0.0, 1.0)
            sk[down] = dist - big_v * t_a * _smooth_integral(x)
            vk[down] = big_v * _smooth(x)
            ak[down] = -big_v / t_a * _smooth_rate(x)
            s[m] = p.s_start_m[k] + sk
            v[m] = vk
            a[m] = ak
        s[before] = 0.0
        s[after] = self.length_m
        return s, v, a

    def _heading(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Heading change from the start (rad) and curvature (1/m, + = right) at ``s``."""
        g = self._seg
        idx: IntArray = np.clip(
            np.searchsorted(g["s0"], s, side="right") - 1, 0, g["s0"].size - 1
        ).astype(np.int64)
        u = np.clip(s - g["s0"][idx], 0.0, g["length"][idx])
        psi = g["psi0"][idx].copy()
        kap = np.zeros_like(s)
        turn = g["kappa"][idx] != 0.0
        if np.any(turn):
            ti = idx[turn]
            k0, lt, lng, th = g["kappa"][ti], g["ramp"][ti], g["length"][ti], g["theta"][ti]
            ut = u[turn]
            up = ut < lt
            down = ut > lng - lt
            x_up = np.clip(ut / lt, 0.0, 1.0)
            x_dn = np.clip((lng - ut) / lt, 0.0, 1.0)
            dpsi = np.where(
                up,
                k0 * lt * _smooth_integral(x_up),
                np.where(down, th - k0 * lt * _smooth_integral(x_dn), k0 * (ut - 0.5 * lt)),
            )
            kt = np.where(up, k0 * _smooth(x_up), np.where(down, k0 * _smooth(x_dn), k0))
            psi[turn] += dpsi
            kap[turn] = kt
        return psi, kap

    def evaluate(self, t_s: FloatArray) -> KinematicState:
        """Exact state at route times ``t_s`` (s, shape (n,)); see `KinematicState`.

        Before 0 the vehicle stands at the start, after `duration_s` at the end; the
        roll/pitch oscillations continue.
        """
        t = np.asarray(t_s, dtype=np.float64)
        mo = self.motion
        s, v, a = self._along(t)
        dpsi, kap = self._heading(s)
        yaw = math.radians(mo.initial_yaw_deg) + dpsi
        yaw_rate = kap * v
        k_u = 2.0 * math.pi / mo.undulation_wavelength_m
        amp = mo.undulation_amplitude_m
        h = amp * np.sin(k_u * s)
        slope = amp * k_u * np.cos(k_u * s)
        curv = -amp * k_u * k_u * np.sin(k_u * s)
        w_r = 2.0 * math.pi / mo.roll_period_s
        w_p = 2.0 * math.pi / mo.pitch_period_s
        a_r = math.radians(mo.roll_amplitude_deg)
        a_p = math.radians(mo.pitch_amplitude_deg)
        roll = a_r * np.sin(w_r * t)
        roll_rate = a_r * w_r * np.cos(w_r * t)
        pitch = np.arctan(slope) + a_p * np.sin(w_p * t + math.pi / 3.0)
        pitch_rate = curv * v / (1.0 + slope**2) + a_p * w_p * np.cos(w_p * t + math.pi / 3.0)
        cy, sy = np.cos(yaw), np.sin(yaw)
        vel = np.column_stack([v * cy, v * sy, 0.0 - v * slope])
        acc = np.column_stack(
            [
                a * cy - v * v * kap * sy,
                a * sy + v * v * kap * cy,
                -a * slope - v * v * curv,
            ]
        )
        return KinematicState(
            t_s=t,
            s_m=s,
            speed_m_s=v,
            acc_m_s2=a,
            rpy_rad=np.column_stack([roll, pitch, yaw]),
            rpy_rate_rad_s=np.column_stack([roll_rate, pitch_rate, yaw_rate]),
            height_m=h,
            height_rate_m_s=v * slope,
            vel_ned_m_s=vel,
            acc_ned_m_s2=acc,
        )


def turn_chord_m(angle_deg: float, radius_m: float, transition_fraction: float) -> FloatArray:
    """Displacement of a turn in its entry frame (forward, right), shape (2,) (m).

    Gauss–Legendre quadrature of the exact heading over the turn (flat-Earth plan view).
    A symmetric turn displaces along its bisector, ``angle / 2`` from the entry heading.
    """
    kin = RouteKinematics(
        Route((Turn(angle_deg, radius_m),), transition_fraction=transition_fraction)
    )
    length = _segment_length_m(Turn(angle_deg, radius_m), transition_fraction)
    x, w = np.polynomial.legendre.leggauss(_GL_NODES)
    n_pieces = 64
    edges = np.linspace(0.0, length, n_pieces + 1)
    half = 0.5 * np.diff(edges)
    nodes = (edges[:-1, None] + half[:, None] * (x[None, :] + 1.0)).ravel()
    weights = (half[:, None] * w[None, :]).ravel()
    psi, _ = kin._heading(nodes)
    return np.array([np.sum(weights * np.cos(psi)), np.sum(weights * np.sin(psi))])


def _check_count(value: int, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        msg = f"{name} must be a whole number >= 1, got {value!r}"
        raise _err(msg)
    return int(value)


def oval_route(
    *,
    speed_m_s: float = 2.0,
    straight_m: float = 40.0,
    radius_m: float = 10.0,
    laps: int = 1,
    static_s: float = 30.0,
    end_static_s: float = 0.0,
    max_acc_m_s2: float = 0.5,
    clockwise: bool = True,
) -> Route:
    """An oval (a race track): straight, 180 deg turn, straight, 180 deg turn, ``laps`` times.

    Starts at the beginning of a straight from standstill, ends where it started (whole
    laps close exactly: the two ends are the same symmetric turn). Defaults: 2 m/s,
    40 m straights, 10 m tightest radius (lap of 158.5 m, about 79 s), one lap,
    30 s static start.

    Parameters
    ----------
    speed_m_s : float
        Cruise speed (m/s).
    straight_m : float
        Length of each straight (m).
    radius_m : float
        Tightest radius of the end turns (m). With the curvature transitions the oval is
        ``turn_chord_m(180, R, 0.25)[1] = 2.022 R`` wide (centre line to centre line).
    laps : int
        Number of laps (>= 1).
    static_s, end_static_s : float
        Standstill before and after (s).
    max_acc_m_s2 : float
        Peak longitudinal acceleration (m/s^2).
    clockwise : bool
        Turn right (True) or left.
    """
    n = _check_count(laps, "laps")
    sign = 1.0 if clockwise else -1.0
    lap: tuple[Segment, ...] = (
        Straight(straight_m),
        Turn(sign * 180.0, radius_m),
        Straight(straight_m),
        Turn(sign * 180.0, radius_m),
    )
    return Route(
        lap * n,
        speed_m_s=speed_m_s,
        max_acc_m_s2=max_acc_m_s2,
        static_s=static_s,
        end_static_s=end_static_s,
    )


def figure_eight_route(
    *,
    speed_m_s: float = 2.0,
    radius_m: float = 8.0,
    crossing_angle_deg: float = 60.0,
    laps: int = 3,
    static_s: float = 30.0,
    end_static_s: float = 0.0,
    max_acc_m_s2: float = 0.5,
) -> Route:
    """A figure-eight driven ``laps`` times: passes its crossing point twice per lap.

    With ``beta = crossing_angle_deg / 2``, starting at the crossing point along the
    initial heading: straight ``a``, left turn of ``180 + 2 beta``, straight ``2a``
    through the crossing point (heading ``180 - 2 beta`` from the initial one), right
    turn of ``180 + 2 beta``, straight ``a`` back to the start. ``a = c / (2 sin beta)``
    with ``c`` the turn's chord, so each lap closes exactly. The crossing point is passed
    ``2 laps`` times in two directions, each straight ``laps`` times:
    a loop that crosses a target's plane several times. Defaults: 2 m/s, 8 m radius,
    60 deg crossing, 3 laps (six passes of the crossing), 30 s static start.

    Parameters
    ----------
    speed_m_s : float
        Cruise speed (m/s).
    radius_m : float
        Tightest radius of the loops (m).
    crossing_angle_deg : float
        Angle between the two legs at the crossing point (deg, 10 to 170).
    laps : int
        Number of laps (>= 1).
    static_s, end_static_s, max_acc_m_s2 : float
        As in `Route`.
    """
    n = _check_count(laps, "laps")
    cross = finite_number(crossing_angle_deg, "crossing_angle_deg")
    if not 10.0 <= cross <= 170.0:
        msg = f"crossing_angle_deg must be within [10, 170], got {cross}"
        raise _err(msg)
    beta = 0.5 * cross
    theta = 180.0 + 2.0 * beta
    frac = DEFAULT_TRANSITION_FRACTION
    chord = float(np.hypot(*turn_chord_m(theta, positive_number(radius_m, "radius_m"), frac)))
    a = chord / (2.0 * math.sin(math.radians(beta)))
    lap: tuple[Segment, ...] = (
        Straight(a),
        Turn(-theta, radius_m),
        Straight(2.0 * a),
        Turn(theta, radius_m),
        Straight(a),
    )
    return Route(
        lap * n,
        speed_m_s=speed_m_s,
        max_acc_m_s2=max_acc_m_s2,
        static_s=static_s,
        end_static_s=end_static_s,
    )


def survey_lines_route(
    *,
    speed_m_s: float = 2.0,
    line_length_m: float = 100.0,
    line_spacing_m: float = 20.0,
    n_lines: int = 4,
    static_s: float = 30.0,
    end_static_s: float = 0.0,
    max_acc_m_s2: float = 0.5,
) -> Route:
    """Parallel straight survey lines joined by alternating 180 deg U-turns.

    Line 1 heads along the initial heading; line 2 comes back ``line_spacing_m`` to the
    right, line 3 another spacing further right, and so on (a lawn-mower pattern, as a
    survey vessel or a mapping car drives). The U-turn radius is set so that the lines
    are exactly ``line_spacing_m`` apart (a U-turn displaces purely sideways; its
    tightest radius is ``line_spacing_m / turn_chord_m(180, 1)``). Defaults: 2 m/s,
    four 100 m lines 20 m apart, 30 s static start.

    Parameters
    ----------
    speed_m_s : float
        Cruise speed (m/s).
    line_length_m, line_spacing_m : float
        Line length and spacing (m).
    n_lines : int
        Number of lines (>= 1).
    static_s, end_static_s, max_acc_m_s2 : float
        As in `Route`.
    """
    n = _check_count(n_lines, "n_lines")
    spacing = positive_number(line_spacing_m, "line_spacing_m")
    frac = DEFAULT_TRANSITION_FRACTION
    radius = spacing / float(np.hypot(*turn_chord_m(180.0, 1.0, frac)))
    segs: list[Segment] = [Straight(line_length_m)]
    for i in range(1, n):
        segs.append(Turn(180.0 if i % 2 else -180.0, radius))
        segs.append(Straight(line_length_m))
    return Route(
        tuple(segs),
        speed_m_s=speed_m_s,
        max_acc_m_s2=max_acc_m_s2,
        static_s=static_s,
        end_static_s=end_static_s,
    )
