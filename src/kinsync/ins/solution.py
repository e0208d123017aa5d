"""Result of the INS/GNSS filter or smoother.

The navigation solution at the IMU rate with its standard deviations and the estimated
sensor biases.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray
from kinsync.frames import euler_rpy_to_quaternion
from kinsync.trajectory import Trajectory

__all__ = ["InitialState", "NavSolution"]


@dataclass(frozen=True)
class InitialState:
    """Navigation state the mechanisation starts from (IMU reference point).

    Attributes
    ----------
    t_s : float
        Time of the state (s).
    lat_deg, lon_deg, h_m : float
        Geodetic position (WGS84).
    vel_ned_m_s : (float, float, float)
        Velocity over the Earth, NED (m/s).
    rpy_rad : (float, float, float)
        Roll, pitch, yaw (DIN 9300, rad), body -> NED.
    gyro_bias_rad_s, acc_bias_m_s2 : (float, float, float)
        Initial estimates of the gyro and accelerometer turn-on biases (body frame),
        e.g. a laboratory calibration, subtracted from the IMU samples; the filter
        estimates the remainder (its initial σ: ``InsConfig.gyro_bias_sigma_rad_s``,
        ``acc_bias_sigma_m_s2``). Zero by default. A configuration may give them
        instead, with their σ (``InsConfig.init_gyro_bias_rad_s``, ...).
    levelling_std_rad : float or None
        Set when roll and pitch were levelled from the mean specific force of a static
        period (`kinsync.ins.alignment.align_static_gnss_heading`): the σ of that
        mean's noise over g (rad). The tilt error is then the horizontal accelerometer
        error over g plus this noise, and the filter's initial roll and pitch σ say so
        (`kinsync.ins.filter.initial_covariance`) instead of taking the configured σ.
        None (default): the attitude comes from elsewhere (a reference), with the
        configured σ.
    gyro_bias_std_rad_s : (float, float, float) or None
        Set when ``gyro_bias_rad_s`` was measured as the mean rate of a static period:
        the σ of that mean's noise (rad/s, body frame); the filter's initial gyro bias
        σ then follows from it (`kinsync.ins.filter.initial_covariance`) instead of the
        turn-on σ. None (default): the turn-on σ, or the calibration's.
    static_until_s : float or None
        Set by a static alignment: the end of the standstill the record starts with
        (s), when the vehicle first moves. Until then the filter keeps the levelled
        attitude in the Jacobian of the accelerometer errors (a first-estimates
        Jacobian, `kinsync.ins._ekf`): the levelled tilt and the horizontal
        accelerometer error cannot be told apart at rest, and re-linearising about an
        attitude that the GNSS updates move gains information on them that is not in
        the data. With ``levelling_std_rad`` it also makes the filter carry the
        second-order vertical support of the levelled tilt as one more state
        (`kinsync.ins.standstill`). None (default): no such standstill.
    """

    t_s: float
    lat_deg: float
    lon_deg: float
    h_m: float
    vel_ned_m_s: tuple[float, float, float]
    rpy_rad: tuple[float, float, float]
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    acc_bias_m_s2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    levelling_std_rad: float | None = None
    gyro_bias_std_rad_s: tuple[float, float, float] | None = None
    static_until_s: float | None = None


@dataclass(frozen=True, eq=False)
class NavSolution(ReadOnlyArrays):
    """Navigation solution (IMU reference point), one row per IMU epoch.

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Epoch times (s).
    lat_deg, lon_deg, h_m : ndarray, shape (n,)
        Geodetic position of the IMU (WGS84).
    vel_ned_m_s : ndarray, shape (n, 3)
        Velocity over the Earth, NED (m/s).
    rpy_rad : ndarray, shape (n, 3)
        Roll, pitch, yaw (DIN 9300, rad), body -> NED.
    std_pos_ned_m, std_vel_ned_m_s, std_att_rad : ndarray, shape (n, 3)
        1σ of position (N, E, D m), velocity, and misorientation (about N, E, D axes, rad).
    gyro_bias_rad_s, acc_bias_m_s2 : ndarray, shape (n, 3)
        Estimated gyro and accelerometer bias (turn-on plus in-run instability), body
        frame.
    std_gyro_bias_rad_s, std_acc_bias_m_s2 : ndarray, shape (n, 3)
        Their 1σ.
    smoothed : bool
        True for the RTS-smoothed solution, False for the forward filter.
    n_gnss_used, n_gnss_rejected : int
        GNSS epochs used and rejected by the χ² gate.
    gyro_scale_ppm, acc_scale_ppm : ndarray, shape (n, 3), or None
        Estimated scale factor errors (ppm) when the filter models them.
    std_gyro_scale_ppm, std_acc_scale_ppm : ndarray, shape (n, 3), or None
        Their 1σ (ppm).
    """

    t_s: FloatArray
    lat_deg: FloatArray
    lon_deg: FloatArray
    h_m: FloatArray
    vel_ned_m_s: FloatArray
    rpy_rad: FloatArray
    std_pos_ned_m: FloatArray
    std_vel_ned_m_s: FloatArray
    std_att_rad: FloatArray
    gyro_bias_rad_s: FloatArray
    acc_bias_m_s2: FloatArray
    std_gyro_bias_rad_s: FloatArray
    std_acc_bias_m_s2: FloatArray
    smoothed: bool = False
    n_gnss_used: int = 0
    n_gnss_rejected: int = 0
    gyro_scale_ppm: FloatArray | None = None
    acc_scale_ppm: FloatArray | None = None
    std_gyro_scale_ppm: FloatArray | None = None
    std_acc_scale_ppm: FloatArray | None = None

    def __len__(self) -> int:
        return int(self.t_s.size)

    def std_rpy_rad(self) -> FloatArray:
        """1σ of roll, pitch and yaw (rad), shape (n, 3), from ``std_att_rad``.

        To first order a misorientation ψ about N, E, D is ``E · δ(roll, pitch, yaw)``,
        the columns of ``E`` being the roll axis (body x), the pitch axis (y turned by
        the yaw) and the yaw axis (down) in NED; so ``δroll = (cos y ψ_N + sin y ψ_E) /
        cos p``, ``δpitch = -sin y ψ_N + cos y ψ_E``, ``δyaw = ψ_D + tan p (cos y ψ_N +
        sin y ψ_E)``, and each σ is the root sum of squares of its terms. The solution
        keeps no correlation between the σ about N, E and D, taken here as none. At a
        yaw of 0 and level these are the σ about N, E, D; near ±90° pitch the roll and
        yaw σ grow without bound (Euler angles are singular there).
        """
        _, pitch, yaw = np.asarray(self.rpy_rad, dtype=np.float64).T
        s_n, s_e, s_d = np.asarray(self.std_att_rad, dtype=np.float64).T
        cos_p = np.maximum(np.abs(np.cos(pitch)), 1e-12)
        level = np.hypot(np.cos(yaw) * s_n, np.sin(yaw) * s_e)  # σ of cos y ψ_N + sin y ψ_E
        out: FloatArray = np.column_stack(
            [
                level / cos_p,
                np.hypot(np.sin(yaw) * s_n, np.cos(yaw) * s_e),
                np.hypot(s_d, np.abs(np.sin(pitch)) / cos_p * level),
            ]
        )
        return out

    def to_trajectory(self) -> Trajectory:
        """The solution as a geodetic `Trajectory` (with velocities) for georeferencing."""
        q = euler_rpy_to_quaternion(self.rpy_rad[:, 0], self.rpy_rad[:, 1], self.rpy_rad[:, 2])
        return Trajectory(
            t_s=np.asarray(self.t_s),
            q_body_to_ned=q,
            lat_lon_h=np.column_stack([self.lat_deg, self.lon_deg, self.h_m]),
            vel_ned_m_s=np.asarray(self.vel_ned_m_s),
        )
