"""Drive simulator: trajectory generator, inverse mechanisation into IMU data, GNSS.

1. **Truth.** A `Route` (straight runs, turns, stops; smooth speed ramps and curvature
   transitions, see `kinsync.sim._route`) plus a `VehicleMotion` (initial heading,
   vessel roll/pitch oscillation, height undulation) give exact, smooth kinematics:
   path length, speed, acceleration, heading, curvature, Euler angles and their rates
   at any time. `simulate_truth` samples them at exactly ``rate_hz`` and integrates
   the geodetic position on the WGS84 ellipsoid from the exact NED velocity:
   ``lat' = v_N / (R_M + h)``, ``lon' = v_E / ((R_N + h) cos lat)`` with 4-point
   Gauss–Legendre quadrature per record interval (order 8) and a fixed-point pass on
   the radii; the height is analytic. The result is a `DriveTrajectory` — a
   `Trajectory` that keeps the exact kinematics for the IMU simulation.
2. **IMU.** `simulate_imu` computes the angular rate of the body w.r.t. inertial space
   ``w_ib = w_nb + C_n^b (w_ie + w_en)`` and the specific force
   ``f = C_n^b (v' + (2 w_ie + w_en) x v - g)`` (normal gravity along +Down) from
   the exact derivatives, and outputs at each time ``t_k`` their mean over
   ``(t_{k-1}, t_k]`` (4-point Gauss–Legendre): what an integrating IMU outputs as
   increments divided by the interval. An `ImuErrorModel` then adds scale factor,
   misalignment, turn-on bias, Gauss–Markov bias variation and white noise.
3. **GNSS.** `simulate_gnss` gives antenna positions (lever arm rotated by the true
   attitude) and velocities (with ``w_eb x l``), white noise per axis, epochs at whole
   multiples of the period, outages removed.
4. **Navigation-solution noise.** `noisy_trajectory` perturbs a truth with smooth,
   correlated position and attitude errors (a stand-in for an INS/GNSS solution).
5. **Files.** `simulate_drive` / `write_drive_simulation`: ``imu.csv``, ``gnss.csv``,
   ``truth.csv``, ``truth.json`` (set-up, seed, injected errors), ``ins.toml`` (a
   matching filter configuration).

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, sections 2.4 (radii), 5.4 (NED mechanisation),
4.4 (IMU error models); J. A. Farrell, *Aided Navigation*, McGraw-Hill, 2008, ch. 4
(Gauss–Markov processes).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from kinsync._typing import FloatArray
from kinsync._validate import finite_number, positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    ecef_to_geodetic,
    euler_rpy_to_matrix,
    euler_rpy_to_quaternion,
    geodetic_to_ecef,
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_ned_to_ecef,
    skew,
)
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.measurements import GnssData, ImuData
from kinsync.ins.solution import InitialState
from kinsync.io.atomic import atomic_write_text, output_folder
from kinsync.io.gnss_csv import write_gnss_csv
from kinsync.io.imu_csv import write_imu_csv
from kinsync.io.ins_config import write_ins_config
from kinsync.io.nav_csv import write_truth_csv
from kinsync.sim._route import (
    KinematicState,
    Route,
    RouteKinematics,
    Segment,
    Stop,
    Straight,
    Turn,
    VehicleMotion,
    figure_eight_route,
    oval_route,
    survey_lines_route,
    turn_chord_m,
)
from kinsync.trajectory import Trajectory

__all__ = [
    "DRIVE_FILES",
    "IMU_KINDS",
    "ROUTE_KINDS",
    "DriveSimConfig",
    "DriveSimulation",
    "DriveTrajectory",
    "ImuErrorModel",
    "ImuErrorTruth",
    "KinematicState",
    "Route",
    "RouteKinematics",
    "Segment",
    "Stop",
    "Straight",
    "Turn",
    "VehicleMotion",
    "figure_eight_route",
    "ideal_imu_mean",
    "initial_state",
    "noisy_trajectory",
    "oval_route",
    "simulate_drive",
    "simulate_gnss",
    "simulate_imu",
    "simulate_truth",
    "survey_lines_route",
    "turn_chord_m",
    "write_drive_simulation",
]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(4)
_GL_NODES = 0.5 * (_GL_X + 1.0)
"""Gauss–Legendre nodes on [0, 1]."""
_GL_WEIGHTS = 0.5 * _GL_W
"""Their weights (sum 1: the mean over the interval)."""
_CHUNK = 100_000
"""Intervals evaluated at once (bounds memory on long drives)."""
_RADII_PASSES = 3


@dataclass(frozen=True, eq=False)
class DriveTrajectory(Trajectory):
    """A geodetic `Trajectory` made by `simulate_truth`, keeping its exact kinematics.

    Attributes
    ----------
    kinematics : RouteKinematics or None
        The route's exact kinematics; route time 0 is ``route_start_s``.
    route_start_s : float
        Time of the route start on this trajectory's time scale (s).
    """

    kinematics: RouteKinematics | None = field(default=None, repr=False)
    route_start_s: float = 0.0

    def state(self, t_s: FloatArray) -> KinematicState:
        """Exact kinematic state at times ``t_s`` (s, this trajectory's scale), shape (n,)."""
        if self.kinematics is None:
            msg = "this DriveTrajectory carries no kinematics; build it with simulate_truth"
            raise InputError(msg)
        return self.kinematics.evaluate(np.asarray(t_s, dtype=np.float64) - self.route_start_s)


def _interval_nodes(t: FloatArray) -> FloatArray:
    """Gauss–Legendre nodes of each interval ``(t[k-1], t[k]]``, shape (len(t) - 1, 4)."""
    dt = np.diff(t)
    out: FloatArray = t[:-1, None] + dt[:, None] * _GL_NODES[None, :]
    return out


def _integrate_latlon_rad(
    kin: RouteKinematics, t_rel: FloatArray, lat0_rad: float, lon0_rad: float, h0_m: float
) -> tuple[FloatArray, FloatArray]:
    """Latitude and longitude (rad) at route times ``t_rel`` by quadrature of the velocity."""
    n = t_rel.size
    dlat = np.empty(n - 1)
    dlon = np.empty(n - 1)
    lat_grid = np.full(n, lat0_rad)
    for lo in range(0, n - 1, _CHUNK):
        hi = min(lo + _CHUNK, n - 1)
        nodes = _interval_nodes(t_rel[lo : hi + 1])
        st = kin.evaluate(nodes.ravel())
        v_n = st.vel_ned_m_s[:, 0].reshape(nodes.shape)
        v_e = st.vel_ned_m_s[:, 1].reshape(nodes.shape)
        h = (h0_m + st.height_m).reshape(nodes.shape)
        dt = np.diff(t_rel[lo : hi + 1])
        lat_nodes = np.full(nodes.shape, lat0_rad)
        for _ in range(_RADII_PASSES):
            r_m, _r_n = radii_m(lat_nodes)
            dlat[lo:hi] = ((v_n / (r_m + h)) @ _GL_WEIGHTS) * dt
            start = lat_grid[lo]
            seg = start + np.concatenate([[0.0], np.cumsum(dlat[lo:hi])])
            lat_nodes = np.interp(nodes, t_rel[lo : hi + 1], seg)
        lat_grid[lo : hi + 1] = seg
        _r_m, r_n = radii_m(lat_nodes)
        dlon[lo:hi] = ((v_e / ((r_n + h) * np.cos(lat_nodes))) @ _GL_WEIGHTS) * dt
    lat = lat0_rad + np.concatenate([[0.0], np.cumsum(dlat)])
    lon = lon0_rad + np.concatenate([[0.0], np.cumsum(dlon)])
    return lat, lon


def simulate_truth(
    route: Route,
    *,
    rate_hz: float = 200.0,
    origin_lat_lon_h: tuple[float, float, float] = (46.8, -71.2, 10.0),
    initial_yaw_deg: float = 0.0,
    roll_amplitude_deg: float = 0.0,
    roll_period_s: float = 6.0,
    pitch_amplitude_deg: float = 0.0,
    pitch_period_s: float = 8.0,
    undulation_amplitude_m: float = 0.0,
    undulation_wavelength_m: float = 50.0,
    t_start_s: float = 0.0,
    duration_s: float | None = None,
) -> DriveTrajectory:
    """Sample a route's exact motion as a geodetic trajectory with velocities.

    Parameters
    ----------
    route : Route
        What is driven (`oval_route`, `figure_eight_route`, `survey_lines_route`, or
        a hand-made `Route`).
    rate_hz : float
        Record rate (Hz); records at exactly ``t_start_s + k / rate_hz``.
    origin_lat_lon_h : (float, float, float)
        Start position (lat_deg, lon_deg, h_m ellipsoidal, WGS84).
    initial_yaw_deg : float
        Heading at the start (deg, clockwise from North).
    roll_amplitude_deg, roll_period_s : float
        Roll oscillation ``A sin(2 pi t / P)`` (vessel), t from the route start.
    pitch_amplitude_deg, pitch_period_s : float
        Pitch oscillation ``A sin(2 pi t / P + pi / 3)``.
    undulation_amplitude_m, undulation_wavelength_m : float
        Height ``A sin(2 pi s / lambda)`` along the path length ``s``; pitch follows.
    t_start_s : float
        Time of the route start on the output time scale (s).
    duration_s : float, optional
        Length of the record (s); default the route's duration. Longer: standstill at
        the end; shorter: cut while driving.

    Returns
    -------
    DriveTrajectory
        ``lat_lon_h`` (deg, deg, m), ``vel_ned_m_s`` (exact), attitude body -> NED;
        positions are the integral of the velocities (against a 1600 Hz integration of
        a 3-lap oval: within 2e-9 m, the float64 resolution of ECEF, at 50 Hz and
        above; 1.3e-8 m at 10 Hz).

    Raises
    ------
    InputError
        Bad rate, origin, motion parameters or duration.
    """
    rate = positive_number(rate_hz, "simulate_truth rate_hz")
    t0 = finite_number(t_start_s, "simulate_truth t_start_s")
    lat0, lon0, h0 = (finite_number(v, "origin_lat_lon_h") for v in origin_lat_lon_h)
    if abs(lat0) > 85.0:
        msg = f"origin latitude {lat0} deg: keep within +-85 deg (longitude rate singular)"
        raise InputError(msg)
    motion = VehicleMotion(
        initial_yaw_deg=initial_yaw_deg,
        roll_amplitude_deg=roll_amplitude_deg,
        roll_period_s=roll_period_s,
        pitch_amplitude_deg=pitch_amplitude_deg,
        pitch_period_s=pitch_period_s,
        undulation_amplitude_m=undulation_amplitude_m,
        undulation_wavelength_m=undulation_wavelength_m,
    )
    kin = RouteKinematics(route, motion)
    span = kin.duration_s if duration_s is None else positive_number(duration_s, "duration_s")
    n = math.floor(span * rate + 1e-9) + 1
    if n < 2:
        msg = f"duration {span} s at {rate} Hz gives fewer than 2 records"
        raise InputError(msg)
    t_rel = np.arange(n, dtype=np.float64) / rate
    st = kin.evaluate(t_rel)
    lat, lon = _integrate_latlon_rad(kin, t_rel, math.radians(lat0), math.radians(lon0), h0)
    lon_deg = (np.degrees(lon) + 180.0) % 360.0 - 180.0
    llh = np.column_stack([np.degrees(lat), lon_deg, h0 + st.height_m])
    q = euler_rpy_to_quaternion(st.rpy_rad[:, 0], st.rpy_rad[:, 1], st.rpy_rad[:, 2])
    return DriveTrajectory(
        t_s=t0 + t_rel,
        q_body_to_ned=q,
        lat_lon_h=llh,
        vel_ned_m_s=st.vel_ned_m_s,
        kinematics=kin,
        route_start_s=t0,
    )


# ---------------------------------------------------------------------- IMU error model
Vector3 = tuple[float, float, float]

_DEG_H = math.pi / 180.0 / 3600.0
"""1 deg/h in rad/s."""
_DEG_RTH = math.pi / 180.0 / 60.0
"""1 deg/sqrt(h) in rad/s/sqrt(Hz)."""
_MG = 9.80665e-3
"""1 mg in m/s^2."""
_IMU_STREAM = 1
_GNSS_STREAM = 2
_NOISE_STREAM = 3
_GYRO_SIGMA_FLOOR_RAD_S = 1e-12
_ACC_SIGMA_FLOOR_M_S2 = 1e-10


def _vector3(value: object, name: str) -> Vector3:
    if not isinstance(value, Iterable):
        msg = f"{name}: expected 3 numbers, got {value!r}"
        raise InputError(msg)
    vals = tuple(value)
    if len(vals) != 3:
        msg = f"{name}: expected 3 numbers, got {len(vals)}"
        raise InputError(msg)
    x, y, z = (finite_number(v, f"{name}[{i}]") for i, v in enumerate(vals))
    return (x, y, z)


def _non_negative(value: object, name: str) -> float:
    out = finite_number(value, name)
    if out < 0.0:
        msg = f"{name} must be >= 0, got {value!r}"
        raise InputError(msg)
    return out


@dataclass(frozen=True)
class ImuErrorModel:
    """IMU sensor errors and output rate (SI units; see `kinsync.ins.config`).

    A measured sample is ``(I + S + M) x_true + b_turn_on + b_gm(t) + n``: scale factor
    ``S = diag(ppm * 1e-6)``, misalignment ``M`` (off-diagonal, small angles), turn-on
    bias, first-order Gauss–Markov bias variation (stationary, started from its
    steady-state distribution) and white noise of density ``N`` (a mean-rate sample over
    ``dt`` has ``sigma = N / sqrt(dt)``). Quantities with a ``_sigma`` name are drawn per
    axis from N(0, sigma^2) with the seed; a fixed vector, where given, replaces the draw.

    Attributes
    ----------
    rate_hz : float
        Output rate (Hz).
    gyro_arw_rad_s_rthz, acc_vrw_m_s2_rthz : float
        White-noise densities (rad/s/sqrt(Hz), m/s^2/sqrt(Hz)), >= 0.
    gyro_bias_sigma_rad_s, acc_bias_sigma_m_s2 : float
        Turn-on bias sigma per axis, >= 0.
    gyro_bias_rad_s, acc_bias_m_s2 : (float, float, float) or None
        Fixed turn-on bias vectors (replace the draw).
    gyro_bias_instability_rad_s, acc_bias_instability_m_s2 : float
        Gauss–Markov steady-state sigma, >= 0.
    gyro_bias_corr_time_s, acc_bias_corr_time_s : float
        Gauss–Markov correlation times (s), > 0.
    gyro_scale_sigma_ppm, acc_scale_sigma_ppm : float
        Scale factor error sigma per axis (ppm), >= 0.
    gyro_scale_ppm, acc_scale_ppm : (float, float, float) or None
        Fixed scale factor errors (ppm).
    gyro_misalignment_sigma_rad, acc_misalignment_sigma_rad : float
        Sigma of each of the six off-diagonal misalignment terms (rad), >= 0.
    name : str
        Label written to ``truth.json``.
    """

    rate_hz: float = 200.0
    gyro_arw_rad_s_rthz: float = 0.0
    acc_vrw_m_s2_rthz: float = 0.0
    gyro_bias_sigma_rad_s: float = 0.0
    acc_bias_sigma_m_s2: float = 0.0
    gyro_bias_rad_s: Vector3 | None = None
    acc_bias_m_s2: Vector3 | None = None
    gyro_bias_instability_rad_s: float = 0.0
    acc_bias_instability_m_s2: float = 0.0
    gyro_bias_corr_time_s: float = 3600.0
    acc_bias_corr_time_s: float = 3600.0
    gyro_scale_sigma_ppm: float = 0.0
    acc_scale_sigma_ppm: float = 0.0
    gyro_scale_ppm: Vector3 | None = None
    acc_scale_ppm: Vector3 | None = None
    gyro_misalignment_sigma_rad: float = 0.0
    acc_misalignment_sigma_rad: float = 0.0
    name: str = "custom"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("rate_hz", "gyro_bias_corr_time_s", "acc_bias_corr_time_s"):
            set_(self, name, positive_number(getattr(self, name), f"IMU error model {name}"))
        for name in (
            "gyro_arw_rad_s_rthz",
            "acc_vrw_m_s2_rthz",
            "gyro_bias_sigma_rad_s",
            "acc_bias_sigma_m_s2",
            "gyro_bias_instability_rad_s",
            "acc_bias_instability_m_s2",
            "gyro_scale_sigma_ppm",
            "acc_scale_sigma_ppm",
            "gyro_misalignment_sigma_rad",
            "acc_misalignment_sigma_rad",
        ):
            set_(self, name, _non_negative(getattr(self, name), f"IMU error model {name}"))
        for name in ("gyro_bias_rad_s", "acc_bias_m_s2", "gyro_scale_ppm", "acc_scale_ppm"):
            value = getattr(self, name)
            if value is not None:
                set_(self, name, _vector3(value, f"IMU error model {name}"))

    @classmethod
    def navigation_grade(cls, *, rate_hz: float = 50.0) -> ImuErrorModel:
        """Ring-laser navigation-grade unit of SPEC section 6 at 50 Hz.

        Gyro turn-on bias 0.01 deg/h, scale 20 ppm, ARW 0.002 deg/sqrt(h), bias
        instability 0.003 deg/h (1 h); accelerometer bias 0.06 mg, scale 5 ppm,
        VRW 10 ug/sqrt(Hz), bias instability 0.02 mg (1 h). The bias, scale and rate
        are the issue's; noise densities and instabilities are typical of the class.
        """
        return cls(
            rate_hz=rate_hz,
            gyro_arw_rad_s_rthz=0.002 * _DEG_RTH,
            acc_vrw_m_s2_rthz=10e-6 * 9.80665,
            gyro_bias_sigma_rad_s=0.01 * _DEG_H,
            acc_bias_sigma_m_s2=0.06 * _MG,
            gyro_bias_instability_rad_s=0.003 * _DEG_H,
            acc_bias_instability_m_s2=0.02 * _MG,
            gyro_bias_corr_time_s=3600.0,
            acc_bias_corr_time_s=3600.0,
            gyro_scale_sigma_ppm=20.0,
            acc_scale_sigma_ppm=5.0,
            name="navigation-grade RLG",
        )

    @classmethod
    def mems(cls, *, rate_hz: float = 200.0) -> ImuErrorModel:
        """ADIS16488-like MEMS unit at 200 Hz (the NaveGo synthetic set's ``imu2``).

        ARW 0.3 deg/sqrt(h), VRW 0.029 m/s/sqrt(h), turn-on bias 0.2 deg/s and 16 mg,
        bias instability 6.5 deg/h and 0.1 mg (100 s), no scale factor error (as in
        ``/work/shared/data/navego-synthetic/imu_gnss_spec.json``).
        """
        return cls(
            rate_hz=rate_hz,
            gyro_arw_rad_s_rthz=0.3 * _DEG_RTH,
            acc_vrw_m_s2_rthz=0.029 / 60.0,
            gyro_bias_sigma_rad_s=0.2 * math.pi / 180.0,
            acc_bias_sigma_m_s2=16.0 * _MG,
            gyro_bias_instability_rad_s=6.5 * _DEG_H,
            acc_bias_instability_m_s2=0.1 * _MG,
            gyro_bias_corr_time_s=100.0,
            acc_bias_corr_time_s=100.0,
            name="MEMS (ADIS16488-like)",
        )

    @classmethod
    def error_free(cls, *, rate_hz: float = 200.0) -> ImuErrorModel:
        """No sensor error at all: the exact mean rates and specific forces."""
        return cls(rate_hz=rate_hz, name="error-free")

    def to_ins_config(self, **overrides: Any) -> InsConfig:
        """A filter configuration matching this model.

        Noise densities, Gauss–Markov sigma and correlation times as in the model; the
        turn-on bias sigma is the model's sigma, or the largest component of a fixed
        bias vector. Zero terms become a tiny positive floor (the filter needs > 0).

        Parameters
        ----------
        **overrides
            Other `InsConfig` fields (``gnss_std_pos_ned_m``,
            ``antenna_lever_arm_body_m``, ``init_std_att_rad``, ...).
        """

        def turn_on(sigma: float, fixed: Vector3 | None) -> float:
            return sigma if fixed is None else max(abs(v) for v in fixed)

        base = InsConfig(
            gyro_arw_rad_s_rthz=max(self.gyro_arw_rad_s_rthz, _GYRO_SIGMA_FLOOR_RAD_S),
            acc_vrw_m_s2_rthz=max(self.acc_vrw_m_s2_rthz, _ACC_SIGMA_FLOOR_M_S2),
            gyro_bias_sigma_rad_s=max(
                turn_on(self.gyro_bias_sigma_rad_s, self.gyro_bias_rad_s),
                _GYRO_SIGMA_FLOOR_RAD_S,
            ),
            acc_bias_sigma_m_s2=max(
                turn_on(self.acc_bias_sigma_m_s2, self.acc_bias_m_s2), _ACC_SIGMA_FLOOR_M_S2
            ),
            gyro_bias_instability_rad_s=max(
                self.gyro_bias_instability_rad_s, _GYRO_SIGMA_FLOOR_RAD_S
            ),
            acc_bias_instability_m_s2=max(self.acc_bias_instability_m_s2, _ACC_SIGMA_FLOOR_M_S2),
            gyro_bias_corr_time_s=self.gyro_bias_corr_time_s,
            acc_bias_corr_time_s=self.acc_bias_corr_time_s,
        )
        try:
            return replace(base, **overrides)
        except TypeError as err:
            msg = f"to_ins_config: {err}"
            raise InputError(msg) from err


@dataclass(frozen=True, eq=False)
class ImuErrorTruth:
    """The sensor errors actually injected by `simulate_imu`.

    Attributes
    ----------
    model : ImuErrorModel
    seed : int
    t_s : ndarray, shape (n,)
        Sample times (s).
    gyro_bias_rad_s, acc_bias_m_s2 : ndarray, shape (3,)
        Turn-on biases, body frame.
    gyro_scale_ppm, acc_scale_ppm : ndarray, shape (3,)
        Scale factor errors (ppm).
    gyro_misalignment_rad, acc_misalignment_rad : ndarray, shape (3, 3)
        Misalignment matrices M (zero diagonal).
    gyro_bias_variation_rad_s, acc_bias_variation_m_s2 : ndarray, shape (n, 3)
        Gauss–Markov bias variation at each sample.
    """

    model: ImuErrorModel
    seed: int
    t_s: FloatArray
    gyro_bias_rad_s: FloatArray
    acc_bias_m_s2: FloatArray
    gyro_scale_ppm: FloatArray
    acc_scale_ppm: FloatArray
    gyro_misalignment_rad: FloatArray
    acc_misalignment_rad: FloatArray
    gyro_bias_variation_rad_s: FloatArray
    acc_bias_variation_m_s2: FloatArray

    def gyro_bias_total_rad_s(self) -> FloatArray:
        """Turn-on bias plus variation at each sample, shape (n, 3) (rad/s)."""
        out: FloatArray = self.gyro_bias_rad_s[None, :] + self.gyro_bias_variation_rad_s
        return out

    def acc_bias_total_m_s2(self) -> FloatArray:
        """Turn-on bias plus variation at each sample, shape (n, 3) (m/s^2)."""
        out: FloatArray = self.acc_bias_m_s2[None, :] + self.acc_bias_variation_m_s2
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the bias variation as its first, mean and last value)."""

        def series(a: FloatArray) -> dict[str, list[float]]:
            return {
                "first": a[0].tolist(),
                "mean": a.mean(axis=0).tolist(),
                "last": a[-1].tolist(),
            }

        return {
            "model": asdict(self.model),
            "seed": self.seed,
            "gyro_bias_rad_s": self.gyro_bias_rad_s.tolist(),
            "acc_bias_m_s2": self.acc_bias_m_s2.tolist(),
            "gyro_scale_ppm": self.gyro_scale_ppm.tolist(),
            "acc_scale_ppm": self.acc_scale_ppm.tolist(),
            "gyro_misalignment_rad": self.gyro_misalignment_rad.tolist(),
            "acc_misalignment_rad": self.acc_misalignment_rad.tolist(),
            "gyro_bias_variation_rad_s": series(self.gyro_bias_variation_rad_s),
            "acc_bias_variation_m_s2": series(self.acc_bias_variation_m_s2),
        }


# ---------------------------------------------------------------------- inverse mechanisation
def _earth_and_transport_rate_ned(
    lat_rad: FloatArray, h_m: FloatArray, vel_ned_m_s: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Earth rate and transport rate in NED (rad/s), each shape (n, 3) (Groves 5.4)."""
    r_m, r_n = radii_m(lat_rad)
    zero = np.zeros_like(lat_rad)
    w_ie = OMEGA_IE_RAD_S * np.column_stack([np.cos(lat_rad), zero, -np.sin(lat_rad)])
    v_n, v_e = vel_ned_m_s[:, 0], vel_ned_m_s[:, 1]
    w_en = np.column_stack(
        [v_e / (r_n + h_m), -v_n / (r_m + h_m), -v_e * np.tan(lat_rad) / (r_n + h_m)]
    )
    return w_ie, w_en


def _origin_height_m(truth: DriveTrajectory) -> float:
    assert truth.lat_lon_h is not None
    st = truth.state(truth.t_s[:1])
    return float(truth.lat_lon_h[0, 2] - st.height_m[0])


def _ideal_imu(
    truth: DriveTrajectory, t_nodes: FloatArray
) -> tuple[FloatArray, FloatArray, KinematicState]:
    """Exact ``w_ib`` (rad/s) and specific force (m/s^2), body frame, at times ``t_nodes``."""
    assert truth.lat_lon_h is not None
    st = truth.state(t_nodes)
    lat = np.radians(np.interp(t_nodes, truth.t_s, truth.lat_lon_h[:, 0]))
    h = _origin_height_m(truth) + st.height_m
    w_ie, w_en = _earth_and_transport_rate_ned(lat, h, st.vel_ned_m_s)
    g = normal_gravity_m_s2(lat, h)
    f_ned = st.acc_ned_m_s2 + np.cross(2.0 * w_ie + w_en, st.vel_ned_m_s)
    f_ned[:, 2] -= g
    R = euler_rpy_to_matrix(st.rpy_rad[:, 0], st.rpy_rad[:, 1], st.rpy_rad[:, 2])
    gyro = st.rate_nb_body_rad_s() + np.einsum("nji,nj->ni", R, w_ie + w_en)
    acc = np.einsum("nji,nj->ni", R, f_ned)
    return gyro, acc, st


def ideal_imu_mean(truth: DriveTrajectory, t_s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Exact mean angular rate and specific force over each interval ``(t[k] - dt_k, t[k]]``.

    Parameters
    ----------
    truth : DriveTrajectory
        From `simulate_truth` (exact kinematics).
    t_s : ndarray, shape (n,)
        Sample times (s), strictly increasing, n >= 2; the first interval has the
        length of the second.

    Returns
    -------
    gyro_body_rad_s, acc_body_m_s2 : ndarray, shape (n, 3)
        Mean of ``w_ib`` and of the specific force over each interval, body frame.

    Notes
    -----
    4-point Gauss–Legendre quadrature per interval: exact to rounding on the smooth
    pieces of the motion. Where an interval holds a junction of the speed or curvature
    ramps (the third derivative of the acceleration jumps there) the error of that one
    sample reaches, on a 5 m-radius oval at 3 m/s with roll, 2e-9 rad/s and 6e-9 m/s^2
    at 50 Hz, 4e-11 rad/s and 2e-10 m/s^2 at 200 Hz (against 32-fold subdivision):
    far below the noise of any IMU.
    """
    t = np.asarray(t_s, dtype=np.float64)
    edges = np.concatenate([[t[0] - (t[1] - t[0])], t])
    gyro = np.empty((t.size, 3))
    acc = np.empty((t.size, 3))
    for lo in range(0, t.size, _CHUNK):
        hi = min(lo + _CHUNK, t.size)
        nodes = _interval_nodes(edges[lo : hi + 1])
        g, a, _ = _ideal_imu(truth, nodes.ravel())
        gyro[lo:hi] = np.einsum("nkj,k->nj", g.reshape(*nodes.shape, 3), _GL_WEIGHTS)
        acc[lo:hi] = np.einsum("nkj,k->nj", a.reshape(*nodes.shape, 3), _GL_WEIGHTS)
    return gyro, acc


def _gauss_markov(
    rng: np.random.Generator, n: int, sigma: float, corr_time_s: float, dt_s: float
) -> FloatArray:
    """Stationary first-order Gauss–Markov sequence, shape (n, 3)."""
    if sigma == 0.0:
        return np.zeros((n, 3))
    phi = math.exp(-dt_s / corr_time_s)
    drive = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), (n, 3))
    drive[0] = rng.normal(0.0, sigma, 3)
    out: FloatArray = lfilter([1.0], [1.0, -phi], drive, axis=0)
    return out


def _draw(rng: np.random.Generator, sigma: float, fixed: Vector3 | None) -> FloatArray:
    return np.array(fixed, dtype=np.float64) if fixed is not None else rng.normal(0.0, sigma, 3)


def _misalignment(rng: np.random.Generator, sigma: float) -> FloatArray:
    m = rng.normal(0.0, sigma, (3, 3)) if sigma > 0.0 else np.zeros((3, 3))
    np.fill_diagonal(m, 0.0)
    return m


def simulate_imu(
    truth: Trajectory,
    model: ImuErrorModel,
    *,
    rate_hz: float | None = None,
    seed: int = 0,
) -> tuple[ImuData, ImuErrorTruth]:
    """IMU samples of a simulated drive, with the model's errors (inverse mechanisation).

    Samples at ``t_start + k / rate`` over the truth's span; the sample at ``t_k`` is
    the mean over ``(t_{k-1}, t_k]`` of the exact ``w_ib`` and specific force
    (`ideal_imu_mean`; the first sample's interval starts before the truth, where the
    route stands still), then the errors of ``model`` (class docstring) are applied.

    Parameters
    ----------
    truth : Trajectory
        A `DriveTrajectory` from `simulate_truth` (its exact kinematics are used).
    model : ImuErrorModel
        Sensor errors and default rate.
    rate_hz : float, optional
        Output rate (Hz); the model's by default.
    seed : int
        Seed of the error draws (same seed, same data).

    Returns
    -------
    (ImuData, ImuErrorTruth)

    Raises
    ------
    InputError
        ``truth`` without exact kinematics, a bad rate, or fewer than 2 samples.
    """
    if not isinstance(truth, DriveTrajectory) or truth.kinematics is None:
        msg = (
            "simulate_imu needs the DriveTrajectory made by simulate_truth (exact "
            "kinematics); a sliced, shifted or file trajectory has lost them"
        )
        raise InputError(msg)
    rate = model.rate_hz if rate_hz is None else positive_number(rate_hz, "IMU rate_hz")
    n = math.floor(truth.duration_s * rate + 1e-9) + 1
    if n < 2:
        msg = f"truth span {truth.duration_s} s at {rate} Hz gives fewer than 2 IMU samples"
        raise InputError(msg)
    t = truth.t_start_s + np.arange(n, dtype=np.float64) / rate
    t[-1] = min(t[-1], truth.t_end_s)
    gyro_true, acc_true = ideal_imu_mean(truth, t)
    rng = np.random.default_rng([int(seed), _IMU_STREAM])
    m = model
    dt = 1.0 / rate
    b_g = _draw(rng, m.gyro_bias_sigma_rad_s, m.gyro_bias_rad_s)
    b_a = _draw(rng, m.acc_bias_sigma_m_s2, m.acc_bias_m_s2)
    s_g = _draw(rng, m.gyro_scale_sigma_ppm, m.gyro_scale_ppm)
    s_a = _draw(rng, m.acc_scale_sigma_ppm, m.acc_scale_ppm)
    m_g = _misalignment(rng, m.gyro_misalignment_sigma_rad)
    m_a = _misalignment(rng, m.acc_misalignment_sigma_rad)
    gm_g = _gauss_markov(rng, n, m.gyro_bias_instability_rad_s, m.gyro_bias_corr_time_s, dt)
    gm_a = _gauss_markov(rng, n, m.acc_bias_instability_m_s2, m.acc_bias_corr_time_s, dt)
    noise_g = rng.normal(0.0, m.gyro_arw_rad_s_rthz * math.sqrt(rate), (n, 3))
    noise_a = rng.normal(0.0, m.acc_vrw_m_s2_rthz * math.sqrt(rate), (n, 3))
    k_g = np.eye(3) + np.diag(s_g * 1e-6) + m_g
    k_a = np.eye(3) + np.diag(s_a * 1e-6) + m_a
    gyro = gyro_true @ k_g.T + b_g + gm_g + noise_g
    acc = acc_true @ k_a.T + b_a + gm_a + noise_a
    errors = ImuErrorTruth(
        model=m,
        seed=int(seed),
        t_s=t,
        gyro_bias_rad_s=b_g,
        acc_bias_m_s2=b_a,
        gyro_scale_ppm=s_g,
        acc_scale_ppm=s_a,
        gyro_misalignment_rad=m_g,
        acc_misalignment_rad=m_a,
        gyro_bias_variation_rad_s=gm_g,
        acc_bias_variation_m_s2=gm_a,
    )
    return ImuData(t_s=t, gyro_body_rad_s=gyro, acc_body_m_s2=acc), errors


# ---------------------------------------------------------------------- GNSS
def _outages(outages: object) -> tuple[tuple[float, float], ...]:
    if not isinstance(outages, Iterable):
        msg = f"GNSS outages: expected (start_s, end_s) pairs, got {outages!r}"
        raise InputError(msg)
    out: list[tuple[float, float]] = []
    for i, pair in enumerate(outages):
        if not isinstance(pair, Iterable) or len(vals := tuple(pair)) != 2:
            msg = f"GNSS outage {i}: expected a (start_s, end_s) pair, got {pair!r}"
            raise InputError(msg)
        start = finite_number(vals[0], f"GNSS outage {i} start_s")
        end = finite_number(vals[1], f"GNSS outage {i} end_s")
        if end <= start:
            msg = f"GNSS outage {i}: end {end} s must be after start {start} s"
            raise InputError(msg)
        out.append((start, end))
    return tuple(out)


def _body_rates_at(truth: Trajectory, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``w_nb`` in the body frame and NED velocity at times ``t`` (exact where possible)."""
    if isinstance(truth, DriveTrajectory) and truth.kinematics is not None:
        st = truth.state(t)
        return st.rate_nb_body_rad_s(), st.vel_ned_m_s
    if truth.vel_ned_m_s is None:
        msg = "simulate_gnss: the truth trajectory needs NED velocities (vel_ned_m_s)"
        raise InputError(msg)
    rate = truth.angular_rate_body_rad_s()
    w = np.column_stack([np.interp(t, truth.t_s, rate[:, i]) for i in range(3)])
    v = np.column_stack([np.interp(t, truth.t_s, truth.vel_ned_m_s[:, i]) for i in range(3)])
    return w, v


def simulate_gnss(
    truth: Trajectory,
    *,
    rate_hz: float = 5.0,
    std_pos_ned_m: Vector3 = (0.02, 0.02, 0.04),
    std_vel_ned_m_s: Vector3 = (0.01, 0.01, 0.02),
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0),
    outages: tuple[tuple[float, float], ...] = (),
    seed: int = 0,
) -> GnssData:
    """GNSS antenna fixes along a true trajectory (defaults: RTK at 5 Hz).

    Epochs at whole multiples of ``1 / rate_hz`` within the truth's span (receivers
    align their epochs to GPS time). Antenna position ``p + C_b^n l`` (exact, through
    ECEF), antenna velocity ``v + C_b^n (w_eb x l)`` with ``w_eb = w_nb + C_n^b w_en``
    (expressed in NED at the antenna); white Gaussian noise per NED axis; epochs inside
    an outage ``[start_s, end_s]`` removed; the sigmas given are written per epoch.

    Parameters
    ----------
    truth : Trajectory
        Geodetic true trajectory of the IMU with velocities (a `DriveTrajectory` gives
        exact angular rates; otherwise they are interpolated).
    rate_hz : float
        Epoch rate (Hz).
    std_pos_ned_m : (float, float, float)
        Position noise sigma N, E, D (m), > 0.
    std_vel_ned_m_s : (float, float, float)
        Velocity noise sigma N, E, D (m/s), > 0.
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna phase centre, body frame FRD (m).
    outages : tuple of (start_s, end_s)
        Intervals without fixes (s, the truth's time scale).
    seed : int
        Seed of the noise (same seed, same data).

    Returns
    -------
    GnssData

    Raises
    ------
    InputError
        Bad rate, sigma, lever arm or outage; fewer than 2 epochs left.
    """
    if truth.lat_lon_h is None:
        msg = "simulate_gnss: the truth trajectory must be geodetic (lat_lon_h)"
        raise InputError(msg)
    rate = positive_number(rate_hz, "GNSS rate_hz")
    std_p = np.array([positive_number(v, "GNSS std_pos_ned_m") for v in std_pos_ned_m])
    std_v = np.array([positive_number(v, "GNSS std_vel_ned_m_s") for v in std_vel_ned_m_s])
    if std_p.size != 3 or std_v.size != 3:
        msg = "GNSS std_pos_ned_m and std_vel_ned_m_s: expected 3 values each"
        raise InputError(msg)
    arm = np.array(_vector3(antenna_lever_arm_body_m, "antenna_lever_arm_body_m"))
    k0 = math.ceil(truth.t_start_s * rate - 1e-9)
    k1 = math.floor(truth.t_end_s * rate + 1e-9)
    t = np.arange(k0, k1 + 1, dtype=np.float64) / rate
    t = t[(t >= truth.t_start_s) & (t <= truth.t_end_s)]
    keep = np.ones(t.size, dtype=np.bool_)
    for start, end in _outages(outages):
        keep &= ~((t >= start) & (t <= end))
    t = t[keep]
    if t.size < 2:
        msg = (
            f"GNSS: {t.size} epoch(s) left at {rate} Hz over the truth's "
            f"{truth.duration_s:.3f} s after the outages; shorten the outages or raise the rate"
        )
        raise InputError(msg)
    sample = truth.interpolate(t)
    assert sample.lat_lon_h is not None
    llh = sample.lat_lon_h
    R_bn = sample.R_body_to_ned
    w_nb, vel = _body_rates_at(truth, t)
    lat = np.radians(llh[:, 0])
    _w_ie, w_en = _earth_and_transport_rate_ned(lat, llh[:, 2], vel)
    w_eb = w_nb + np.einsum("nji,nj->ni", R_bn, w_en)
    R_ne = rotation_ned_to_ecef(llh[:, 0], llh[:, 1])
    arm_ned = np.einsum("nij,j->ni", R_bn, arm)
    ecef = geodetic_to_ecef(llh[:, 0], llh[:, 1], llh[:, 2]) + np.einsum(
        "nij,nj->ni", R_ne, arm_ned
    )
    ant = ecef_to_geodetic(ecef)
    v_ecef = np.einsum("nij,nj->ni", R_ne, vel + np.einsum("nij,nj->ni", R_bn, np.cross(w_eb, arm)))
    R_ne_ant = rotation_ned_to_ecef(ant[:, 0], ant[:, 1])
    v_ant = np.einsum("nji,nj->ni", R_ne_ant, v_ecef)
    rng = np.random.default_rng([int(seed), _GNSS_STREAM])
    dp = rng.normal(0.0, 1.0, (t.size, 3)) * std_p
    dv = rng.normal(0.0, 1.0, (t.size, 3)) * std_v
    lat_a = np.radians(ant[:, 0])
    r_m, r_n = radii_m(lat_a)
    lat_deg = ant[:, 0] + np.degrees(dp[:, 0] / (r_m + ant[:, 2]))
    lon_deg = ant[:, 1] + np.degrees(dp[:, 1] / ((r_n + ant[:, 2]) * np.cos(lat_a)))
    return GnssData(
        t_s=t,
        lat_deg=lat_deg,
        lon_deg=(lon_deg + 180.0) % 360.0 - 180.0,
        h_m=ant[:, 2] - dp[:, 2],
        std_pos_ned_m=np.tile(std_p, (t.size, 1)),
        vel_ned_m_s=v_ant + dv,
        std_vel_ned_m_s=np.tile(std_v, (t.size, 1)),
    )


# ---------------------------------------------------------------------- trajectory noise
def noisy_trajectory(
    truth: Trajectory,
    *,
    std_pos_ned_m: Vector3 = (0.02, 0.02, 0.03),
    std_att_deg: Vector3 = (0.005, 0.005, 0.015),
    corr_time_s: float = 5.0,
    seed: int = 0,
) -> Trajectory:
    """A navigation solution: the truth with smooth, correlated position/attitude errors.

    Each error component is a natural cubic spline through independent N(0, sigma^2)
    knots ``corr_time_s`` apart (smooth, correlated over about ``corr_time_s``, RMS
    close to sigma). Position errors are NED (m); attitude errors are small rotations
    about the NED axes (roll, pitch, yaw order of ``std_att_deg``: N, E, D), applied as
    ``R' = (I + [e x]) R``. Velocities get the spline's derivative, so positions and
    velocities stay consistent for Hermite interpolation.

    Parameters
    ----------
    truth : Trajectory
        Geodetic trajectory with velocities.
    std_pos_ned_m : (float, float, float)
        Position error sigma N, E, D (m), >= 0.
    std_att_deg : (float, float, float)
        Misorientation sigma about N, E, D (deg), >= 0.
    corr_time_s : float
        Knot spacing of the error splines (s), > 0.
    seed : int
        Seed (same seed, same errors).

    Returns
    -------
    Trajectory
        Same times; perturbed ``lat_lon_h``, ``q_body_to_ned`` and ``vel_ned_m_s``.
    """
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "noisy_trajectory: the truth must be geodetic with velocities"
        raise InputError(msg)
    sp = np.array([_non_negative(v, "std_pos_ned_m") for v in std_pos_ned_m])
    sa = np.radians([_non_negative(v, "std_att_deg") for v in std_att_deg])
    tau = positive_number(corr_time_s, "corr_time_s")
    rng = np.random.default_rng([int(seed), _NOISE_STREAM])
    n_knots = max(4, math.ceil(truth.duration_s / tau) + 2)
    knots = truth.t_start_s + tau * (np.arange(n_knots) - 1.0)
    spline = CubicSpline(knots, rng.normal(0.0, 1.0, (n_knots, 6)), bc_type="natural")
    e = spline(truth.t_s)
    de = spline(truth.t_s, 1)
    dp, ea = e[:, :3] * sp, e[:, 3:] * sa
    llh = truth.lat_lon_h
    lat = np.radians(llh[:, 0])
    r_m, r_n = radii_m(lat)
    new_llh = np.column_stack(
        [
            llh[:, 0] + np.degrees(dp[:, 0] / (r_m + llh[:, 2])),
            llh[:, 1] + np.degrees(dp[:, 1] / ((r_n + llh[:, 2]) * np.cos(lat))),
            llh[:, 2] - dp[:, 2],
        ]
    )
    new_llh[:, 1] = (new_llh[:, 1] + 180.0) % 360.0 - 180.0
    small = np.eye(3)[None, :, :] + skew(ea)
    R = np.einsum("nij,njk->nik", small, quaternion_to_matrix(truth.q_body_to_ned))
    u, _s, vt = np.linalg.svd(R)
    q = matrix_to_quaternion(u @ vt)
    return Trajectory(
        t_s=truth.t_s,
        q_body_to_ned=q,
        lat_lon_h=new_llh,
        vel_ned_m_s=truth.vel_ned_m_s + de[:, :3] * sp,
    )


# ---------------------------------------------------------------------- complete drive
RouteKind = Literal["oval", "loop", "lines"]
ImuKind = Literal["navigation", "mems"]
ROUTE_KINDS: tuple[RouteKind, ...] = ("oval", "loop", "lines")
"""Route names of `DriveSimConfig.route`: oval, figure-eight loop, survey lines."""
IMU_KINDS: tuple[ImuKind, ...] = ("navigation", "mems")
"""IMU presets of `DriveSimConfig.imu`."""


def _kind_route(kind: RouteKind, speed: float, static_s: float, laps: int) -> Route:
    if kind == "oval":
        return oval_route(speed_m_s=speed, laps=laps, static_s=static_s)
    if kind == "loop":
        return figure_eight_route(speed_m_s=speed, laps=laps, static_s=static_s)
    return survey_lines_route(speed_m_s=speed, n_lines=laps, static_s=static_s)


@dataclass(frozen=True)
class DriveSimConfig:
    """Set-up of a simulated drive (defaults: one oval lap at 2 m/s, RLG IMU, RTK 5 Hz).

    Attributes
    ----------
    route : {"oval", "loop", "lines"}
        `oval_route`, `figure_eight_route` or `survey_lines_route` (their defaults).
    speed_m_s : float
        Cruise speed (m/s).
    laps : int or None
        Laps (oval, loop) or lines (lines); default: enough to fill ``duration_s``,
        else 1 lap / 2 loops / 4 lines.
    duration_s : float or None
        Record length (s); default the route's. The route is cut (or extended at
        standstill) to this length.
    static_s : float
        Standstill at the start (s), for static levelling.
    imu : {"navigation", "mems"}
        `ImuErrorModel.navigation_grade` or `ImuErrorModel.mems`.
    imu_rate_hz : float or None
        IMU rate (Hz); default the preset's (50 or 200 Hz). The truth has the same rate.
    gnss_rate_hz : float
        GNSS epoch rate (Hz).
    gnss_std_pos_ned_m, gnss_std_vel_ned_m_s : (float, float, float)
        GNSS noise sigma N, E, D (m, m/s).
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> antenna, body FRD (m).
    gnss_outages : tuple of (start_s, end_s)
        GNSS outages (s, on the output time scale).
    origin_lat_lon_h : (float, float, float)
        Start position (deg, deg, m).
    initial_yaw_deg : float
        Start heading (deg).
    roll_amplitude_deg, roll_period_s, pitch_amplitude_deg, pitch_period_s : float
        Vessel roll/pitch oscillations (deg, s).
    undulation_amplitude_m, undulation_wavelength_m : float
        Height undulation along the path (m).
    t_start_s : float
        Time of the first record (s).
    seed : int
        Seed (same seed, same data).
    """

    route: RouteKind = "oval"
    speed_m_s: float = 2.0
    laps: int | None = None
    duration_s: float | None = None
    static_s: float = 60.0
    imu: ImuKind = "navigation"
    imu_rate_hz: float | None = None
    gnss_rate_hz: float = 5.0
    gnss_std_pos_ned_m: Vector3 = (0.02, 0.02, 0.04)
    gnss_std_vel_ned_m_s: Vector3 = (0.01, 0.01, 0.02)
    antenna_lever_arm_body_m: Vector3 = (0.3, -0.2, -1.5)
    gnss_outages: tuple[tuple[float, float], ...] = ()
    origin_lat_lon_h: Vector3 = (46.8, -71.2, 10.0)
    initial_yaw_deg: float = 35.0
    roll_amplitude_deg: float = 0.0
    roll_period_s: float = 6.0
    pitch_amplitude_deg: float = 0.0
    pitch_period_s: float = 8.0
    undulation_amplitude_m: float = 0.0
    undulation_wavelength_m: float = 50.0
    t_start_s: float = 0.0
    seed: int = 1

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.route not in ROUTE_KINDS:
            msg = f"drive simulation: route must be oval, loop or lines, got {self.route!r}"
            raise InputError(msg)
        if self.imu not in IMU_KINDS:
            msg = f"drive simulation: imu must be navigation or mems, got {self.imu!r}"
            raise InputError(msg)
        set_(self, "speed_m_s", positive_number(self.speed_m_s, "speed_m_s"))
        set_(self, "static_s", _non_negative(self.static_s, "static_s"))
        set_(self, "gnss_rate_hz", positive_number(self.gnss_rate_hz, "gnss_rate_hz"))
        set_(self, "t_start_s", finite_number(self.t_start_s, "t_start_s"))
        for name in ("duration_s", "imu_rate_hz"):
            value = getattr(self, name)
            if value is not None:
                set_(self, name, positive_number(value, name))
        if self.laps is not None:
            set_(self, "laps", _count(self.laps, "laps"))
        if isinstance(self.seed, bool) or not isinstance(self.seed, int | np.integer):
            msg = f"drive simulation: seed must be a whole number, got {self.seed!r}"
            raise InputError(msg)
        if self.seed < 0:
            msg = f"drive simulation: seed must be >= 0, got {self.seed}"
            raise InputError(msg)
        set_(self, "seed", int(self.seed))
        for name in (
            "gnss_std_pos_ned_m",
            "gnss_std_vel_ned_m_s",
            "antenna_lever_arm_body_m",
            "origin_lat_lon_h",
        ):
            set_(self, name, _vector3(getattr(self, name), name))
        set_(self, "gnss_outages", _outages(self.gnss_outages))

    def imu_model(self) -> ImuErrorModel:
        """The IMU preset at the configured rate."""
        if self.imu == "navigation":
            model = ImuErrorModel.navigation_grade()
        else:
            model = ImuErrorModel.mems()
        return model if self.imu_rate_hz is None else replace(model, rate_hz=self.imu_rate_hz)

    def build_route(self) -> Route:
        """The route, with laps enough for ``duration_s`` unless ``laps`` is given."""
        default = {"oval": 1, "loop": 2, "lines": 4}[self.route]
        laps = self.laps
        if laps is None and self.duration_s is not None:
            one = _kind_route(self.route, self.speed_m_s, self.static_s, 1)
            two = _kind_route(self.route, self.speed_m_s, self.static_s, 2)
            per_lap = two.duration_s - one.duration_s
            laps = max(1, math.ceil((self.duration_s - one.duration_s) / per_lap) + 1)
        return _kind_route(self.route, self.speed_m_s, self.static_s, laps or default)


def _count(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        msg = f"drive simulation: {name} must be a whole number >= 1, got {value!r}"
        raise InputError(msg)
    return int(value)


@dataclass(frozen=True, eq=False)
class DriveSimulation:
    """A simulated drive with its ground truth.

    Attributes
    ----------
    config : DriveSimConfig
    route : Route
    truth : DriveTrajectory
        True IMU trajectory at the IMU rate (``truth.csv``).
    imu : ImuData
        IMU samples with errors (``imu.csv``).
    imu_errors : ImuErrorTruth
        Injected sensor errors.
    gnss : GnssData
        Antenna fixes (``gnss.csv``).
    ins_config : InsConfig
        Filter configuration matching the IMU and GNSS models (``ins.toml``).
    truth_doc : dict
        Set-up, seed and injected errors (``truth.json``).
    """

    config: DriveSimConfig
    route: Route
    truth: DriveTrajectory
    imu: ImuData
    imu_errors: ImuErrorTruth
    gnss: GnssData
    ins_config: InsConfig
    truth_doc: dict[str, Any]

    def initial_state(self) -> InitialState:
        """The true state at the first record (to start a mechanisation or filter)."""
        return initial_state(self.truth)


def initial_state(truth: Trajectory, index: int = 0) -> InitialState:
    """The true navigation state of a geodetic trajectory at record ``index``."""
    if truth.lat_lon_h is None or truth.vel_ned_m_s is None:
        msg = "initial_state: the trajectory must be geodetic with velocities"
        raise InputError(msg)
    rpy = truth.euler_rpy_rad()[index]
    lat, lon, h = truth.lat_lon_h[index]
    v = truth.vel_ned_m_s[index]
    return InitialState(
        t_s=float(truth.t_s[index]),
        lat_deg=float(lat),
        lon_deg=float(lon),
        h_m=float(h),
        vel_ned_m_s=(float(v[0]), float(v[1]), float(v[2])),
        rpy_rad=(float(rpy[0]), float(rpy[1]), float(rpy[2])),
    )


def simulate_drive(config: DriveSimConfig | None = None) -> DriveSimulation:
    """Simulate a drive: truth, IMU with errors, GNSS (module docstring).

    Parameters
    ----------
    config : DriveSimConfig, optional
        Set-up; the defaults otherwise.

    Returns
    -------
    DriveSimulation

    Raises
    ------
    InputError
        An invalid set-up.
    """
    c = config or DriveSimConfig()
    route = c.build_route()
    model = c.imu_model()
    truth = simulate_truth(
        route,
        rate_hz=model.rate_hz,
        origin_lat_lon_h=c.origin_lat_lon_h,
        initial_yaw_deg=c.initial_yaw_deg,
        roll_amplitude_deg=c.roll_amplitude_deg,
        roll_period_s=c.roll_period_s,
        pitch_amplitude_deg=c.pitch_amplitude_deg,
        pitch_period_s=c.pitch_period_s,
        undulation_amplitude_m=c.undulation_amplitude_m,
        undulation_wavelength_m=c.undulation_wavelength_m,
        t_start_s=c.t_start_s,
        duration_s=c.duration_s,
    )
    imu, errors = simulate_imu(truth, model, seed=c.seed)
    gnss = simulate_gnss(
        truth,
        rate_hz=c.gnss_rate_hz,
        std_pos_ned_m=c.gnss_std_pos_ned_m,
        std_vel_ned_m_s=c.gnss_std_vel_ned_m_s,
        antenna_lever_arm_body_m=c.antenna_lever_arm_body_m,
        outages=c.gnss_outages,
        seed=c.seed,
    )
    ins_config = model.to_ins_config(
        gnss_std_pos_ned_m=c.gnss_std_pos_ned_m,
        gnss_std_vel_ned_m_s=c.gnss_std_vel_ned_m_s,
        antenna_lever_arm_body_m=c.antenna_lever_arm_body_m,
    )
    doc: dict[str, Any] = {
        "config": asdict(c),
        "seed": c.seed,
        "route": {
            "length_m": route.length_m,
            "duration_s": route.duration_s,
            "segments": [{"type": type(s).__name__, **asdict(s)} for s in route.segments],
            "speed_m_s": route.speed_m_s,
            "max_acc_m_s2": route.max_acc_m_s2,
            "static_s": route.static_s,
            "transition_fraction": route.transition_fraction,
        },
        "t_start_s": truth.t_start_s,
        "t_end_s": truth.t_end_s,
        "n_imu": len(imu),
        "n_gnss": len(gnss),
        "imu_rate_hz": model.rate_hz,
        "imu_errors": errors.to_dict(),
        "antenna_lever_arm_body_m": list(c.antenna_lever_arm_body_m),
        "gnss_outages": [list(o) for o in c.gnss_outages],
        "initial_state": asdict(initial_state(truth)),
        "conventions": (
            "body X forward, Y right, Z down; NED; DIN 9300 roll/pitch/yaw; IMU sample k "
            "= mean rate / specific force over (t[k-1], t[k]]"
        ),
    }
    return DriveSimulation(
        config=c,
        route=route,
        truth=truth,
        imu=imu,
        imu_errors=errors,
        gnss=gnss,
        ins_config=ins_config,
        truth_doc=doc,
    )


DRIVE_FILES = ("imu.csv", "gnss.csv", "truth.csv", "truth.json", "ins.toml")
"""Files `write_drive_simulation` writes."""


def write_drive_simulation(sim: DriveSimulation, out_dir: Path) -> None:
    """Write ``imu.csv``, ``gnss.csv``, ``truth.csv``, ``truth.json``, ``ins.toml``.

    ``imu.csv``: ``t_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,acc_x_m_s2,acc_y_m_s2,
    acc_z_m_s2``. ``gnss.csv``: ``t_s,lat_deg,lon_deg,h_m,std_n_m,std_e_m,std_d_m,
    vn_m_s,ve_m_s,vd_m_s,std_vn_m_s,std_ve_m_s,std_vd_m_s``. ``truth.csv``:
    ``t_s,lat_deg,lon_deg,h_m,vn_m_s,ve_m_s,vd_m_s,roll_deg,pitch_deg,yaw_deg`` (as the
    NaveGo reference set). Floats with ``repr`` precision (exact round trip); each file
    appears only when complete. ``ins.toml``: `kinsync.io.ins_config` format.

    Raises
    ------
    InputError
        ``out_dir`` is an existing file.
    """
    folder = output_folder(out_dir, "give a folder for the simulation")
    write_imu_csv(sim.imu, folder / "imu.csv")
    write_gnss_csv(sim.gnss, folder / "gnss.csv")
    write_truth_csv(sim.truth, folder / "truth.csv")
    atomic_write_text(folder / "truth.json", json.dumps(sim.truth_doc, indent=2) + "\n")
    write_ins_config(sim.ins_config, folder / "ins.toml")
