"""`InsConfig` refuses non-finite and implausible values from Python, as the TOML reader
does (one check: its `kinsync.ins.config.FIELD_SPANS`), naming the field."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from kinsync.errors import InputError
from kinsync.ins.config import FIELD_SPANS, InsConfig

CONFIG = InsConfig(1e-4, 1e-3, 1e-3, 0.01, 1e-5, 1e-4)
CALIBRATED = dataclasses.replace(
    CONFIG,
    init_gyro_bias_rad_s=(1e-3, 0.0, 0.0),
    init_gyro_bias_std_rad_s=(1e-4, 1e-4, 1e-4),
    init_acc_bias_m_s2=(0.01, 0.0, 0.0),
    init_acc_bias_std_m_s2=(1e-3, 1e-3, 1e-3),
)
NUMERIC = [f.name for f in dataclasses.fields(InsConfig)]


def _with(name: str, value: float) -> dict[str, Any]:
    """The change that puts ``value`` into field ``name`` (one component of a vector)."""
    current = getattr(CALIBRATED, name)
    if isinstance(current, tuple):
        return {name: (current[0], value, current[2])}
    return {name: value}


@pytest.mark.parametrize("name", NUMERIC)
@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_every_numeric_field_must_be_finite(name: str, value: float) -> None:
    with pytest.raises(InputError) as info:
        dataclasses.replace(CALIBRATED, **_with(name, value))
    assert name in str(info.value)


def test_a_nan_lever_arm_is_refused() -> None:
    with pytest.raises(InputError, match=r"antenna_lever_arm_body_m: expected 3 finite numbers"):
        dataclasses.replace(CONFIG, antenna_lever_arm_body_m=(math.nan, 0.0, 0.0))


@pytest.mark.parametrize(
    ("name", "value", "words"),
    [
        ("gyro_bias_sigma_rad_s", 1e7, "gyro_bias_sigma_rad_s: 10000000.0 is outside 1e-12 to"),
        ("gnss_std_pos_ned_m", 1e-13, "gnss_std_pos_ned_m[1]: 1e-13 is too small"),
        ("gyro_bias_corr_time_s", 1e11, "gyro_bias_corr_time_s: 100000000000.0 is outside"),
        ("max_imu_gap_s", 1e7, "max_imu_gap_s: 10000000.0 is outside 1e-09 to 1e+06 s"),
        ("antenna_lever_arm_body_m", 2000.0, "antenna_lever_arm_body_m[1]: 2000.0 is outside"),
        ("gyro_scale_factor_sigma_ppm", 1e-9, "gyro_scale_factor_sigma_ppm: 1e-09 is too small"),
        ("init_gyro_bias_rad_s", 20.0, "init_gyro_bias_rad_s[1]: 20.0 is outside -10 to 10 rad/s"),
        ("init_acc_bias_m_s2", -2e3, "init_acc_bias_m_s2[1]: -2000.0 is outside"),
    ],
)
def test_implausible_values_are_refused_as_the_toml_reader_refuses_them(
    name: str, value: float, words: str
) -> None:
    assert name in FIELD_SPANS
    with pytest.raises(InputError) as info:
        dataclasses.replace(CALIBRATED, **_with(name, value))
    assert words in str(info.value)


def test_a_scale_factor_sigma_of_zero_leaves_the_states_out() -> None:
    assert not dataclasses.replace(CONFIG, gyro_scale_factor_sigma_ppm=0.0).models_scale_factors
