"""Configuration of the INS/GNSS filter.

IMU error model, GNSS defaults, lever arm, initial uncertainties (frozen dataclass;
TOML form in ``kinsync.io.ins_config``).

All values in SI units. Noise densities follow the usual convention: angle random walk
in rad/s/sqrt(Hz) (= rad/sqrt(s)), velocity random walk in m/s^2/sqrt(Hz); bias
instability as the steady-state standard deviation of a first-order Gauss–Markov
process with the given correlation time.
"""

from __future__ import annotations

from dataclasses import dataclass

from kinsync._validate import positive_number
from kinsync.errors import InputError

__all__ = ["InsConfig"]

Vector3 = tuple[float, float, float]


@dataclass(frozen=True)
class InsConfig:
    """Filter configuration.

    Attributes
    ----------
    gyro_arw_rad_s_rthz, acc_vrw_m_s2_rthz : float
        White-noise densities of gyros and accelerometers.
    gyro_bias_sigma_rad_s, acc_bias_sigma_m_s2 : float
        Turn-on bias standard deviations (initial σ of the bias states).
    gyro_bias_instability_rad_s, acc_bias_instability_m_s2 : float
        Steady-state σ of the Gauss–Markov bias variation.
    gyro_bias_corr_time_s, acc_bias_corr_time_s : float
        Gauss–Markov correlation times (s).
    gnss_std_pos_ned_m : (float, float, float)
        Default GNSS position σ N, E, D (m) where the file gives none.
    gnss_std_vel_ned_m_s : (float, float, float)
        Default GNSS velocity σ (m/s).
    antenna_lever_arm_body_m : (float, float, float)
        IMU -> GNSS antenna phase centre, body frame (m).
    init_std_att_rad : (float, float, float)
        Initial misorientation σ roll, pitch, yaw (rad).
    init_std_vel_ned_m_s, init_std_pos_ned_m : (float, float, float)
        Initial velocity and position σ.
    max_imu_gap_s : float
        Longest tolerated gap between IMU samples; longer gaps are an input error.
    gate_probability : float
        χ² innovation gate (probability of accepting a good measurement), e.g. 0.9999.
    """

    gyro_arw_rad_s_rthz: float
    acc_vrw_m_s2_rthz: float
    gyro_bias_sigma_rad_s: float
    acc_bias_sigma_m_s2: float
    gyro_bias_instability_rad_s: float
    acc_bias_instability_m_s2: float
    gyro_bias_corr_time_s: float = 3600.0
    acc_bias_corr_time_s: float = 3600.0
    gnss_std_pos_ned_m: Vector3 = (1.0, 1.0, 2.0)
    gnss_std_vel_ned_m_s: Vector3 = (0.1, 0.1, 0.1)
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    init_std_att_rad: Vector3 = (0.01, 0.01, 0.02)
    init_std_vel_ned_m_s: Vector3 = (0.1, 0.1, 0.1)
    init_std_pos_ned_m: Vector3 = (1.0, 1.0, 2.0)
    max_imu_gap_s: float = 0.1
    gate_probability: float = 0.9999

    def __post_init__(self) -> None:
        for name in (
            "gyro_arw_rad_s_rthz",
            "acc_vrw_m_s2_rthz",
            "gyro_bias_sigma_rad_s",
            "acc_bias_sigma_m_s2",
            "gyro_bias_instability_rad_s",
            "acc_bias_instability_m_s2",
            "gyro_bias_corr_time_s",
            "acc_bias_corr_time_s",
            "max_imu_gap_s",
        ):
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        for name in (
            "gnss_std_pos_ned_m",
            "gnss_std_vel_ned_m_s",
            "init_std_att_rad",
            "init_std_vel_ned_m_s",
            "init_std_pos_ned_m",
        ):
            vals = tuple(getattr(self, name))
            if len(vals) != 3:
                msg = f"{name}: expected 3 values, got {len(vals)}"
                raise InputError(msg)
            object.__setattr__(
                self, name, tuple(positive_number(v, f"{name}[{i}]") for i, v in enumerate(vals))
            )
        arm = tuple(float(v) for v in self.antenna_lever_arm_body_m)
        if len(arm) != 3:
            msg = f"antenna_lever_arm_body_m: expected 3 values, got {len(arm)}"
            raise InputError(msg)
        object.__setattr__(self, "antenna_lever_arm_body_m", arm)
        p = float(self.gate_probability)
        if not 0.0 < p < 1.0:
            msg = f"gate_probability must be in (0, 1), got {p}"
            raise InputError(msg)
