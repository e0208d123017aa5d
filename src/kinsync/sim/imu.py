"""Drive simulation, the IMU: inverse mechanisation of the truth and an IMU error model.

`simulate_imu` computes the angular rate of the body w.r.t. inertial space
``w_ib = w_nb + C_n^b (w_ie + w_en)`` and the specific force
``f = C_n^b (v' + (2 w_ie + w_en) x v - g)`` (normal gravity along +Down) from the
exact derivatives of a `kinsync.sim.drive_truth.DriveTrajectory`, and outputs at each
time ``t_k`` their mean over ``(t_{k-1}, t_k]`` (4-point Gauss–Legendre): what an
integrating IMU outputs as increments divided by the interval. An `ImuErrorModel` then
adds scale factor, misalignment, turn-on bias, Gauss–Markov bias variation and white
noise; `ImuErrorTruth` records what was drawn.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation
Systems*, 2nd ed., Artech House, 2013, sections 2.4 (radii), 5.4 (NED mechanisation),
4.4 (IMU error models); J. A. Farrell, *Aided Navigation*, McGraw-Hill, 2008, ch. 4
(Gauss–Markov processes).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from scipy.signal import lfilter

from kinsync._typing import FloatArray
from kinsync._validate import positive_number
from kinsync.errors import InputError
from kinsync.frames import (
    euler_rpy_to_matrix,
)
from kinsync.ins.config import InsConfig
from kinsync.ins.earth import OMEGA_IE_RAD_S, normal_gravity_m_s2, radii_m
from kinsync.ins.measurements import ImuData
from kinsync.sim._common import _IMU_STREAM, Vector3, _non_negative, _vector3
from kinsync.sim._route import (
    KinematicState,
)
from kinsync.sim.drive_truth import _CHUNK, _GL_WEIGHTS, DriveTrajectory, _interval_nodes
from kinsync.trajectory import Trajectory

__all__ = [
    "ImuErrorModel",
    "ImuErrorTruth",
    "ideal_imu_mean",
    "simulate_imu",
]

_DEG_H = math.pi / 180.0 / 3600.0
"""1 deg/h in rad/s."""


_DEG_RTH = math.pi / 180.0 / 60.0
"""1 deg/sqrt(h) in rad/s/sqrt(Hz)."""


_MG = 9.80665e-3
"""1 mg in m/s^2."""


_GYRO_SIGMA_FLOOR_RAD_S = 1e-12


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
        bias vector; the scale factor sigma likewise (the filter then estimates scale
        factors; none when the model has none). Zero terms become a tiny positive floor
        (the filter needs > 0). Misalignments have no filter state.

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
            gyro_scale_factor_sigma_ppm=turn_on(self.gyro_scale_sigma_ppm, self.gyro_scale_ppm),
            acc_scale_factor_sigma_ppm=turn_on(self.acc_scale_sigma_ppm, self.acc_scale_ppm),
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


_ACC_SIGMA_FLOOR_M_S2 = 1e-10
