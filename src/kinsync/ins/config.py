"""Configuration of the INS/GNSS filter.

IMU error model, GNSS defaults, lever arm, initial uncertainties (frozen dataclass;
TOML form in ``kinsync.io.ins_config``).

All values in SI units (scale factors in ppm). Noise densities follow the usual
convention: angle random walk in rad/s/sqrt(Hz) (= rad/sqrt(s)), velocity random walk
in m/s^2/sqrt(Hz). Each sensor's bias is a **turn-on bias** (a random constant with the
datasheet's turn-on σ, or a laboratory calibration with its own σ, the ``init_*_bias``
fields) plus an **in-run instability** (the steady-state σ of a first-order
Gauss–Markov process with the given correlation time): two states per axis in the
filter (`kinsync.ins._ekf`). Scale factor errors are modelled when their σ is given.

Every value must be finite and plausible (`FIELD_SPANS`, in SI units): noise terms and
σ within 1e-12 to 1e6 (the filter squares them and divides by them; the GNSS σ from 1e-6,
as in a GNSS file's σ columns), correlation times
within 1e-9 to 1e10 s, ``max_imu_gap_s`` within 1e-9 to 1e6 s, lever arm components
within ±1000 m, scale factor σ 0 (not modelled) or within 1e-6 to 1e6 ppm, calibrated
biases within ±10 rad/s and ±1000 m/s^2. `InsConfig` refuses anything else naming its
field; the TOML reader runs the same check (`kinsync._validate.check_quantity` with
these spans) first, naming the key as written.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from kinsync._validate import Span, check_quantity, finite_number, finite_vector, positive_number
from kinsync.errors import InputError

__all__ = [
    "BIAS_PAIRS",
    "FIELD_SPANS",
    "GATE_PROBABILITY_MIN",
    "POSITIVE_FIELDS",
    "SCALE_FACTOR_FIELDS",
    "InsConfig",
]

Vector3 = tuple[float, float, float]

GATE_PROBABILITY_MIN = 0.9
"""Lowest χ² gate probability: a lower gate throws away more than a tenth of a good
filter's epochs, and the rejection checks (`kinsync.ins.checks`) could not tell a filter
that disagrees with its GNSS from one that fits."""

POSITIVE_SCALARS = (
    "gyro_arw_rad_s_rthz",
    "acc_vrw_m_s2_rthz",
    "gyro_bias_sigma_rad_s",
    "acc_bias_sigma_m_s2",
    "gyro_bias_instability_rad_s",
    "acc_bias_instability_m_s2",
    "gyro_bias_corr_time_s",
    "acc_bias_corr_time_s",
    "max_imu_gap_s",
)
POSITIVE_VECTORS = (
    "gnss_std_pos_ned_m",
    "gnss_std_vel_ned_m_s",
    "init_std_att_rad",
    "init_std_vel_ned_m_s",
    "init_std_pos_ned_m",
)
BIAS_PAIRS = (
    ("init_gyro_bias_rad_s", "init_gyro_bias_std_rad_s"),
    ("init_acc_bias_m_s2", "init_acc_bias_std_m_s2"),
)
"""Each calibrated turn-on bias and its σ: given together or not at all."""
POSITIVE_FIELDS = frozenset((*POSITIVE_SCALARS, *POSITIVE_VECTORS, *(s for _, s in BIAS_PAIRS)))
"""The fields whose every value must be above 0."""
SCALE_FACTOR_FIELDS = ("gyro_scale_factor_sigma_ppm", "acc_scale_factor_sigma_ppm")
"""Scale factor σ (ppm): 0 leaves the scale factors out of the filter."""

_TERM = Span(1e-12, 1e6, "(SI units)", "an IMU noise or bias term or a standard deviation")
_CORR_TIME = Span(1e-9, 1e10, "s", "a bias correlation time")
_GAP = Span(1e-9, 1e6, "s", "an IMU gap")
_LEVER_ARM = Span(-1000.0, 1000.0, "m", "a lever arm component (beyond any vehicle)")
_PPM = Span(1e-6, 1e6, "ppm", "a scale factor σ")
_GYRO_BIAS = Span(-10.0, 10.0, "rad/s", "a gyro bias (beyond any gyro's range)")
_ACC_BIAS = Span(-1e3, 1e3, "m/s^2", "an accelerometer bias (100 g)")
MIN_GNSS_STD = 1e-6
"""Smallest GNSS position (m) or velocity (m/s) σ, in the configuration as in a GNSS file's
σ columns: the filter weighs an epoch by 1/σ²."""
_GNSS_STD_POS = Span(MIN_GNSS_STD, 1e6, "m", "a GNSS position standard deviation")
_GNSS_STD_VEL = Span(MIN_GNSS_STD, 1e6, "m/s", "a GNSS velocity standard deviation")

FIELD_SPANS: dict[str, Span] = {
    **dict.fromkeys(POSITIVE_FIELDS, _TERM),
    "gyro_bias_corr_time_s": _CORR_TIME,
    "acc_bias_corr_time_s": _CORR_TIME,
    "max_imu_gap_s": _GAP,
    "gnss_std_pos_ned_m": _GNSS_STD_POS,
    "gnss_std_vel_ned_m_s": _GNSS_STD_VEL,
    **dict.fromkeys(SCALE_FACTOR_FIELDS, _PPM),
    "antenna_lever_arm_body_m": _LEVER_ARM,
    "init_gyro_bias_rad_s": _GYRO_BIAS,
    "init_acc_bias_m_s2": _ACC_BIAS,
}
"""Plausible values of each numeric field (SI units; `kinsync._validate.Span`). Noise
densities, bias terms and σ are squared and divided by in the filter, so they must lie
far from 0 and from float64's limits. ``gate_probability`` has its own bounds
(`GATE_PROBABILITY_MIN`, below 1)."""


def _three(value: object, name: str) -> tuple[object, ...]:
    """``value`` as a tuple of 3 items, or `InputError` naming ``name``."""
    if not isinstance(value, Iterable) or isinstance(value, str):
        msg = f"{name}: expected 3 values, got {value!r}"
        raise InputError(msg)
    vals = tuple(value)
    if len(vals) != 3:
        msg = f"{name}: expected 3 values, got {len(vals)}"
        raise InputError(msg)
    return vals


def _finite3(value: object, name: str) -> Vector3:
    vals = finite_vector(value, 3, name)
    return (float(vals[0]), float(vals[1]), float(vals[2]))


@dataclass(frozen=True)
class InsConfig:
    """Filter configuration.

    Attributes
    ----------
    gyro_arw_rad_s_rthz, acc_vrw_m_s2_rthz : float
        White-noise densities of gyros and accelerometers.
    gyro_bias_sigma_rad_s, acc_bias_sigma_m_s2 : float
        Turn-on bias standard deviations (initial σ of the turn-on bias states when no
        calibration is given).
    gyro_bias_instability_rad_s, acc_bias_instability_m_s2 : float
        Steady-state σ of the Gauss–Markov in-run bias variation.
    gyro_bias_corr_time_s, acc_bias_corr_time_s : float
        Gauss–Markov correlation times (s).
    gyro_scale_factor_sigma_ppm, acc_scale_factor_sigma_ppm : float
        Scale factor error σ (ppm); 0 (default) leaves scale factors out of the filter.
        Either one above 0 adds six scale factor states (27 in all).
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
    init_gyro_bias_rad_s, init_acc_bias_m_s2 : (float, float, float) or None
        Turn-on biases known from a laboratory calibration (body frame), the filter's
        starting estimates; None: unknown (estimated from zero).
    init_gyro_bias_std_rad_s, init_acc_bias_std_m_s2 : (float, float, float) or None
        Their σ, given with them, replacing the turn-on σ.
    max_imu_gap_s : float
        Longest tolerated gap between IMU samples; longer gaps are an input error.
    gate_probability : float
        χ² innovation gate (probability of accepting a good measurement), e.g. 0.9999;
        at least `GATE_PROBABILITY_MIN`.
    """

    gyro_arw_rad_s_rthz: float
    acc_vrw_m_s2_rthz: float
    gyro_bias_sigma_rad_s: float
    acc_bias_sigma_m_s2: float
    gyro_bias_instability_rad_s: float
    acc_bias_instability_m_s2: float
    gyro_bias_corr_time_s: float = 3600.0
    acc_bias_corr_time_s: float = 3600.0
    gyro_scale_factor_sigma_ppm: float = 0.0
    acc_scale_factor_sigma_ppm: float = 0.0
    gnss_std_pos_ned_m: Vector3 = (1.0, 1.0, 2.0)
    gnss_std_vel_ned_m_s: Vector3 = (0.1, 0.1, 0.1)
    antenna_lever_arm_body_m: Vector3 = (0.0, 0.0, 0.0)
    init_std_att_rad: Vector3 = (0.01, 0.01, 0.02)
    init_std_vel_ned_m_s: Vector3 = (0.1, 0.1, 0.1)
    init_std_pos_ned_m: Vector3 = (1.0, 1.0, 2.0)
    init_gyro_bias_rad_s: Vector3 | None = None
    init_gyro_bias_std_rad_s: Vector3 | None = None
    init_acc_bias_m_s2: Vector3 | None = None
    init_acc_bias_std_m_s2: Vector3 | None = None
    max_imu_gap_s: float = 0.1
    gate_probability: float = 0.9999

    @property
    def models_scale_factors(self) -> bool:
        """True when scale factor states are in the filter (either σ above 0)."""
        return self.gyro_scale_factor_sigma_ppm > 0.0 or self.acc_scale_factor_sigma_ppm > 0.0

    def __post_init__(self) -> None:
        for name in POSITIVE_SCALARS:
            object.__setattr__(self, name, positive_number(getattr(self, name), name))
        for name in POSITIVE_VECTORS:
            vals = _three(getattr(self, name), name)
            object.__setattr__(
                self, name, tuple(positive_number(v, f"{name}[{i}]") for i, v in enumerate(vals))
            )
        for name in SCALE_FACTOR_FIELDS:
            raw = getattr(self, name)
            try:
                value = finite_number(raw, name)
            except InputError:
                value = math.nan
            if not value >= 0.0:
                msg = f"{name}: must be a number >= 0 (0: not modelled), got {raw!r}"
                raise InputError(msg)
            object.__setattr__(self, name, value)
        for value_name, std_name in BIAS_PAIRS:
            value, std = getattr(self, value_name), getattr(self, std_name)
            if (value is None) != (std is None):
                msg = (
                    f"{value_name} and {std_name} go together: a calibrated turn-on bias "
                    "needs its σ, and a σ its bias"
                )
                raise InputError(msg)
            if value is None:
                continue
            object.__setattr__(self, value_name, _finite3(value, value_name))
            object.__setattr__(
                self,
                std_name,
                tuple(
                    positive_number(v, f"{std_name}[{i}]")
                    for i, v in enumerate(_three(std, std_name))
                ),
            )
        arm = _finite3(self.antenna_lever_arm_body_m, "antenna_lever_arm_body_m")
        object.__setattr__(self, "antenna_lever_arm_body_m", arm)
        p = float(self.gate_probability)
        if not GATE_PROBABILITY_MIN <= p < 1.0:
            msg = (
                f"gate_probability must be in [{GATE_PROBABILITY_MIN}, 1), got {p}: the gate "
                "rejects 1 - p of the epochs of a filter that fits (0.999 or 0.9999 are usual)"
            )
            raise InputError(msg)
        for name, span in FIELD_SPANS.items():
            value = getattr(self, name)
            if value is None or (name in SCALE_FACTOR_FIELDS and value == 0.0):
                continue  # not calibrated, or not modelled
            check_quantity(value, span, name)
