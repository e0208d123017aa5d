"""INS configuration TOML: the shipped NaveGo file, units, round trip, bad input."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.errors import InputError
from kinsync.ins.config import InsConfig
from kinsync.io.ins_config import (
    ins_config_from_toml_text,
    ins_config_to_toml_text,
    read_ins_config,
    write_ins_config,
)

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "navego-adis16488.toml"
SPEC_JSON = (
    Path(__file__).resolve().parents[3]
    / "shared"
    / "data"
    / "navego-synthetic"
    / "imu_gnss_spec.json"
)

MINIMAL = """
[imu]
gyro_arw_rad_s_rthz = 1e-4
acc_vrw_m_s2_rthz = 1e-3
gyro_bias_sigma_rad_s = 1e-3
acc_bias_sigma_m_s2 = 0.01
gyro_bias_instability_rad_s = 1e-5
acc_bias_instability_m_s2 = 1e-4
"""


def _one(values: list[float]) -> float:
    """The JSON gives one value per axis; the configuration holds one per sensor type."""
    assert len(set(values)) == 1, values
    return float(values[0])


def test_shipped_navego_file_equals_the_generator_spec() -> None:
    spec = json.loads(SPEC_JSON.read_text())
    cfg = read_ins_config(SHIPPED)
    pairs = {
        "gyro_arw_rad_s_rthz": "arw",
        "acc_vrw_m_s2_rthz": "vrw",
        "gyro_bias_sigma_rad_s": "gb_sta",
        "acc_bias_sigma_m_s2": "ab_sta",
        "gyro_bias_instability_rad_s": "gb_dyn",
        "acc_bias_instability_m_s2": "ab_dyn",
    }
    for attr, key in pairs.items():  # datasheet units in the file: equal to rounding
        assert getattr(cfg, attr) == pytest.approx(_one(spec[key]), rel=1e-12, abs=0.0), attr
    assert cfg.gyro_bias_corr_time_s == _one(spec["gb_corr"])
    assert cfg.acc_bias_corr_time_s == _one(spec["ab_corr"])
    np.testing.assert_allclose(cfg.gnss_std_pos_ned_m, spec["gnss"]["stdm"], rtol=1e-12)
    np.testing.assert_allclose(cfg.gnss_std_vel_ned_m_s, spec["gnss"]["stdv"], rtol=1e-12)
    np.testing.assert_array_equal(cfg.antenna_lever_arm_body_m, spec["gnss"]["larm"])
    np.testing.assert_allclose(cfg.init_std_att_rad, spec["ini_align_err"], rtol=1e-12)


def test_minimal_file_takes_the_defaults() -> None:
    cfg = ins_config_from_toml_text(MINIMAL)
    defaults = InsConfig(1e-4, 1e-3, 1e-3, 0.01, 1e-5, 1e-4)
    assert cfg == defaults


@pytest.mark.parametrize(
    ("si_key", "alt_key", "alt_value", "si_value"),
    [
        ("gyro_arw_rad_s_rthz", "gyro_arw_deg_rthr", 60.0, math.pi / 180.0),
        ("acc_vrw_m_s2_rthz", "acc_vrw_m_s_rthr", 0.6, 0.01),
        ("gyro_bias_sigma_rad_s", "gyro_bias_sigma_deg_h", 3600.0, math.pi / 180.0),
        ("gyro_bias_sigma_rad_s", "gyro_bias_sigma_deg_s", 2.0, math.pi / 90.0),
        ("acc_bias_sigma_m_s2", "acc_bias_sigma_mg", 1000.0, 9.80665),
        ("gyro_bias_instability_rad_s", "gyro_bias_instability_deg_h", 7200.0, math.pi / 90.0),
        ("gyro_bias_instability_rad_s", "gyro_bias_instability_deg_s", 0.5, math.pi / 360.0),
        ("acc_bias_instability_m_s2", "acc_bias_instability_mg", 0.5, 0.5 * 9.80665e-3),
    ],
)
def test_datasheet_units_convert_to_si(
    si_key: str, alt_key: str, alt_value: float, si_value: float
) -> None:
    text = MINIMAL.replace(f"{si_key} =", f"{alt_key} = {alt_value!r}\n# was ")
    cfg = ins_config_from_toml_text(text)
    assert getattr(cfg, si_key) == pytest.approx(si_value, rel=1e-14)


def test_attitude_sigma_in_degrees() -> None:
    cfg = ins_config_from_toml_text(MINIMAL + "[init]\nstd_att_deg = [1.0, 2.0, 180.0]\n")
    np.testing.assert_allclose(cfg.init_std_att_rad, [math.pi / 180, math.pi / 90, math.pi])


positive = st.floats(1e-9, 1e6, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(positive, positive, positive)
gnss_std = st.floats(1e-6, 1e6, allow_nan=False, allow_infinity=False)
gnss_vec3 = st.tuples(gnss_std, gnss_std, gnss_std)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(positive, min_size=9, max_size=9),
    gnss_vec3,
    gnss_vec3,
    st.tuples(*(st.floats(-10.0, 10.0),) * 3),
    vec3,
    vec3,
    vec3,
    st.floats(0.9, 1.0 - 1e-9, exclude_max=True),
)
def test_round_trip_is_exact(
    scalars: list[float],
    pos: tuple[float, float, float],
    vel: tuple[float, float, float],
    arm: tuple[float, float, float],
    att: tuple[float, float, float],
    init_vel: tuple[float, float, float],
    init_pos: tuple[float, float, float],
    gate: float,
) -> None:
    cfg = InsConfig(
        gyro_arw_rad_s_rthz=scalars[0],
        acc_vrw_m_s2_rthz=scalars[1],
        gyro_bias_sigma_rad_s=scalars[2],
        acc_bias_sigma_m_s2=scalars[3],
        gyro_bias_instability_rad_s=scalars[4],
        acc_bias_instability_m_s2=scalars[5],
        gyro_bias_corr_time_s=scalars[6],
        acc_bias_corr_time_s=scalars[7],
        gnss_std_pos_ned_m=pos,
        gnss_std_vel_ned_m_s=vel,
        antenna_lever_arm_body_m=arm,
        init_std_att_rad=att,
        init_std_vel_ned_m_s=init_vel,
        init_std_pos_ned_m=init_pos,
        max_imu_gap_s=scalars[8],
        gate_probability=gate,
    )
    assert ins_config_from_toml_text(ins_config_to_toml_text(cfg)) == cfg


def test_file_round_trip(tmp_path: Path) -> None:
    cfg = dataclasses.replace(read_ins_config(SHIPPED), antenna_lever_arm_body_m=(0.1, -0.2, -1.5))
    write_ins_config(cfg, tmp_path / "cfg.toml")
    assert read_ins_config(tmp_path / "cfg.toml") == cfg


@pytest.mark.parametrize(
    ("extra", "fragments"),
    [
        ("[imu\n", ["malformed TOML"]),
        ("[gnsss]\nstd_pos_ned_m = [1, 1, 1]\n", ["unknown table", "gnsss"]),
        ("[gnss]\nstd_pos_m = [1, 1, 1]\n", ["unknown key", "[gnss]", "std_pos_m"]),
        ("[init]\nstd_att_deg = [1, 1, 1]\nstd_att_rad = [1, 1, 1]\n", ["two units"]),
        ("[gnss]\nstd_pos_ned_m = [1, 1]\n", ["std_pos_ned_m", "3 numbers"]),
        ("[gnss]\nstd_pos_ned_m = 1.0\n", ["std_pos_ned_m", "3 numbers"]),
        ("[gnss]\nstd_pos_ned_m = [1, 'a', 1]\n", ["std_pos_ned_m[1]", "number"]),
        ("[gnss]\nstd_pos_ned_m = [1, 0, 1]\n", ["[gnss] std_pos_ned_m[1]", "above 0, got 0"]),
        ("[gnss]\nstd_vel_ned_m_s = [1, nan, 1]\n", ["std_vel_ned_m_s[1]", "finite"]),
        ("[filter]\nmax_imu_gap_s = true\n", ["max_imu_gap_s", "number"]),
        ("[filter]\nmax_imu_gap_s = -0.1\n", ["[filter] max_imu_gap_s", "above 0, got -0.1"]),
        ("[filter]\ngate_probability = 1.0\n", ["gate_probability", "[0.9, 1)"]),
        ("[filter]\ngate_probability = 0.5\n", ["gate_probability", "[0.9, 1), got 0.5"]),
        ("[filter]\ngate_probability = '0.99'\n", ["gate_probability", "number"]),
    ],
)
def test_bad_documents(extra: str, fragments: list[str]) -> None:
    with pytest.raises(InputError) as exc:
        ins_config_from_toml_text(MINIMAL + extra, source="cfg.toml")
    message = str(exc.value)
    assert message.startswith("cfg.toml: ")
    for frag in fragments:
        assert frag in message, message


@pytest.mark.parametrize(
    ("top", "fragment"),
    [
        ("title = 'x'\n", "unknown table(s) or top-level key(s) ['title']"),
        ("gnss = 3\n", "gnss must be a table"),
    ],
)
def test_bad_top_level_keys(top: str, fragment: str) -> None:
    with pytest.raises(InputError) as exc:
        ins_config_from_toml_text(top + MINIMAL, source="cfg.toml")
    assert fragment in str(exc.value)


def test_two_units_for_an_imu_term() -> None:
    with pytest.raises(InputError, match=r"gyro_arw_rad_s_rthz.*gyro_arw_deg_rthr.*two units"):
        ins_config_from_toml_text(MINIMAL.replace("[imu]", "[imu]\ngyro_arw_deg_rthr = 0.3"))


def test_missing_required_imu_term_names_both_keys() -> None:
    text = MINIMAL.replace("acc_bias_sigma_m_s2 = 0.01\n", "")
    with pytest.raises(InputError, match="needs acc_bias_sigma_m_s2 or acc_bias_sigma_mg"):
        ins_config_from_toml_text(text)


def test_negative_imu_term_is_rejected() -> None:
    with pytest.raises(
        InputError, match=r"\[imu\] acc_vrw_m_s2_rthz: must be above 0, got -0\.001"
    ):
        ins_config_from_toml_text(
            MINIMAL.replace("acc_vrw_m_s2_rthz = 1e-3", "acc_vrw_m_s2_rthz = -1e-3")
        )


@pytest.mark.parametrize(
    ("replace", "words"),
    [
        (
            ("gyro_bias_instability_rad_s = 1e-5", "gyro_bias_instability_deg_h = -6.5"),
            "[imu] gyro_bias_instability_deg_h: must be above 0, got -6.5",
        ),
        (("[imu]", '[init]\ngyro_bias_deg_h = "720"\n[imu]'), "got '720'"),
    ],
)
def test_messages_name_the_key_and_value_as_written(replace: tuple[str, str], words: str) -> None:
    assert replace[0] in MINIMAL
    with pytest.raises(InputError) as info:
        ins_config_from_toml_text(MINIMAL.replace(*replace), source="cfg.toml")
    assert words in str(info.value)
    assert "rad_s" not in str(info.value)  # the SI name and value are not what was written


def test_micro_g_and_deg_per_second_keys() -> None:
    text = MINIMAL.replace("acc_vrw_m_s2_rthz = 1e-3", "acc_vrw_ug_rthz = 60").replace(
        "gyro_arw_rad_s_rthz", "gyro_arw_deg_s_rthz"
    )
    for stem in ("acc_bias_sigma", "acc_bias_instability"):
        line = next(ln for ln in MINIMAL.splitlines() if ln.startswith(f"{stem}_m_s2"))
        text = text.replace(line, f"{stem}_ug = 100")
    cfg = ins_config_from_toml_text(text)
    ref = ins_config_from_toml_text(MINIMAL)
    assert cfg.acc_vrw_m_s2_rthz == pytest.approx(60 * 9.80665e-6, rel=1e-14)
    assert cfg.acc_bias_sigma_m_s2 == pytest.approx(100 * 9.80665e-6, rel=1e-14)
    assert cfg.acc_bias_instability_m_s2 == pytest.approx(100 * 9.80665e-6, rel=1e-14)
    assert cfg.gyro_arw_rad_s_rthz == pytest.approx(
        ref.gyro_arw_rad_s_rthz * math.pi / 180.0, rel=1e-14
    )


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_ins_config(tmp_path / "none.toml")


# ---------------------------------------------------------------- scale factors, known biases
def test_scale_factor_keys_add_the_scale_states() -> None:
    cfg = ins_config_from_toml_text(
        MINIMAL + "gyro_scale_factor_sigma_ppm = 300.0\nacc_scale_factor_sigma_ppm = 1000\n"
    )
    assert (cfg.gyro_scale_factor_sigma_ppm, cfg.acc_scale_factor_sigma_ppm) == (300.0, 1000.0)
    assert cfg.models_scale_factors
    assert not ins_config_from_toml_text(MINIMAL).models_scale_factors
    assert ins_config_from_toml_text(ins_config_to_toml_text(cfg)) == cfg


@pytest.mark.parametrize(
    ("lines", "gyro_rad_s", "gyro_std_rad_s"),
    [
        (
            "gyro_bias_deg_h = [36.0, -72.0, 3.6]\ngyro_bias_std_deg_h = [1.0, 2.0, 3.0]",
            (math.radians(0.01), math.radians(-0.02), math.radians(0.001)),
            tuple(math.radians(v / 3600.0) for v in (1.0, 2.0, 3.0)),
        ),
        (
            "gyro_bias_deg_s = [0.2, 0.2, -0.2]\ngyro_bias_std_rad_s = [1e-5, 1e-5, 1e-5]",
            (math.radians(0.2), math.radians(0.2), math.radians(-0.2)),
            (1e-5, 1e-5, 1e-5),
        ),
    ],
)
def test_calibrated_turn_on_biases_in_datasheet_units(
    lines: str, gyro_rad_s: tuple[float, ...], gyro_std_rad_s: tuple[float, ...]
) -> None:
    text = (
        MINIMAL + "[init]\n" + lines + "\nacc_bias_mg = [16, -8, 1]\nacc_bias_std_mg = [1, 1, 2]\n"
    )
    cfg = ins_config_from_toml_text(text)
    assert cfg.init_gyro_bias_rad_s is not None
    assert cfg.init_gyro_bias_std_rad_s is not None
    assert cfg.init_acc_bias_m_s2 is not None
    assert cfg.init_acc_bias_std_m_s2 is not None
    np.testing.assert_allclose(cfg.init_gyro_bias_rad_s, np.array(gyro_rad_s), rtol=1e-15)
    np.testing.assert_allclose(cfg.init_gyro_bias_std_rad_s, np.array(gyro_std_rad_s), rtol=1e-15)
    np.testing.assert_allclose(cfg.init_acc_bias_m_s2, np.array([16, -8, 1]) * 9.80665e-3)
    np.testing.assert_allclose(cfg.init_acc_bias_std_m_s2, np.array([1, 1, 2]) * 9.80665e-3)
    assert ins_config_from_toml_text(ins_config_to_toml_text(cfg)) == cfg


@pytest.mark.parametrize(
    ("extra", "fragments"),
    [
        (
            "[init]\ngyro_bias_deg_h = [1, 2, 3]\n",
            ["[init] gyro_bias_deg_h", "gyro_bias_std_deg_h"],
        ),
        (
            "[init]\nacc_bias_std_mg = [1, 1, 1]\n",
            ["[init] acc_bias_std_mg", "without acc_bias_m_s2"],
        ),
        (
            "[init]\ngyro_bias_deg_h = [1, 2, 3]\ngyro_bias_deg_s = [1, 2, 3]\n",
            ["two units"],
        ),
        (
            "[init]\ngyro_bias_rad_s = [1, 2, 300]\ngyro_bias_std_rad_s = [1, 1, 1]\n",
            ["gyro_bias_rad_s[2]", "gyro bias"],
        ),
        (
            "[init]\nacc_bias_mg = [1, 2, 3]\nacc_bias_std_mg = [1, 0, 1]\n",
            ["[init] acc_bias_std_mg[1]", "above 0, got 0"],
        ),
        ("[imu]\ngyro_scale_factor_sigma_ppm = 0\n", ["gyro_scale_factor_sigma_ppm"]),
        ("[imu]\nacc_scale_factor_sigma_ppm = -5\n", ["acc_scale_factor_sigma_ppm"]),
    ],
)
def test_bad_scale_factor_and_bias_keys(extra: str, fragments: list[str]) -> None:
    text = (
        MINIMAL.replace("[imu]\n", "[imu]\n" + extra.split("\n", 1)[1])
        if extra.startswith("[imu]")
        else MINIMAL + extra
    )
    with pytest.raises(InputError) as exc:
        ins_config_from_toml_text(text, source="cfg.toml")
    message = str(exc.value)
    assert message.startswith("cfg.toml: ")
    for frag in fragments:
        assert frag in message, message


@pytest.mark.parametrize(
    ("text", "key", "field", "si_value"),
    [
        (
            MINIMAL.replace("gyro_bias_sigma_rad_s = 1e-3", "gyro_bias_sigma_deg_h = 1e12"),
            "[imu] gyro_bias_sigma_deg_h",
            "gyro_bias_sigma_rad_s",
            1e12 * (math.pi / 180.0 / 3600.0),
        ),
        (MINIMAL + "acc_bias_corr_time_s = 1e11\n", "[imu] acc_bias_corr_time_s", None, 1e11),
        (
            MINIMAL + "[gnss]\nantenna_lever_arm_body_m = [0, 2000, 0]\n",
            "[gnss] antenna_lever_arm_body_m",
            None,
            (0.0, 2000.0, 0.0),
        ),
        (MINIMAL + "[filter]\nmax_imu_gap_s = 1e7\n", "[filter] max_imu_gap_s", None, 1e7),
        # Review L5: 1e-12 was accepted here, while a GNSS file's sigma column refuses it
        (
            MINIMAL + "[gnss]\nstd_pos_ned_m = [1, 1e-12, 1]\n",
            "[gnss] std_pos_ned_m",
            "gnss_std_pos_ned_m",
            (1.0, 1e-12, 1.0),
        ),
        (
            MINIMAL + "[gnss]\nstd_vel_ned_m_s = [1, 1e-7, 1]\n",
            "[gnss] std_vel_ned_m_s",
            "gnss_std_vel_ned_m_s",
            (1.0, 1e-7, 1.0),
        ),
    ],
)
def test_implausible_values_are_refused_from_a_file_and_from_python_alike(
    text: str, key: str, field: str | None, si_value: float | tuple[float, ...]
) -> None:
    """One check for both paths (`InsConfig`'s): the file's message names the key as
    written, the container's the field."""
    field = field or key.split("] ")[1]
    with pytest.raises(InputError) as from_file:
        ins_config_from_toml_text(text, source="cfg.toml")
    changes: dict[str, Any] = {field: si_value}
    valid = ins_config_from_toml_text(MINIMAL)
    with pytest.raises(InputError) as from_python:
        dataclasses.replace(valid, **changes)
    index = "[1]" if isinstance(si_value, tuple) else ""
    file_message, python_message = str(from_file.value), str(from_python.value)
    assert file_message.startswith(f"cfg.toml: {key}{index} (in SI units): ")
    assert python_message.startswith(f"{field}{index}: ")
    assert file_message.split(" (in SI units): ")[1] == python_message.split(": ", 1)[1]
    if field.startswith("gnss_std"):
        assert "at least 1e-06" in file_message  # as a GNSS file's sigma columns


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("gyro_arw_rad_s_rthz", "[" + ", ".join(["1.0"] * 200_000) + "]"),
        ("gyro_arw_rad_s_rthz", '"' + "x" * 200_000 + '"'),
        ("k" * 200_000, "1.0"),
    ],
)
def test_a_long_value_is_cut_short_in_the_message(key: str, value: str) -> None:
    text = MINIMAL.replace("gyro_arw_rad_s_rthz = 1e-4", f"{key} = {value}")
    with pytest.raises(InputError) as info:
        ins_config_from_toml_text(text, source="ins.toml")
    assert len(str(info.value)) < 2000  # the names of the keys expected are listed
    assert "..." in str(info.value)
