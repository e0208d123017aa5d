"""INS/GNSS filter configuration as TOML (the `kinsync.ins.config.InsConfig` fields).

Every key carries its unit in its name. The SI key of each `InsConfig` field is always
accepted; where datasheets use other units, one alternative key per such unit is
accepted too and converted on reading (give one key per quantity, not two)::

    [imu]                                  # required: the six noise and bias terms
    gyro_arw_rad_s_rthz = 8.7e-5           # or gyro_arw_deg_rthr (deg/sqrt(h)), _deg_s_rthz
    acc_vrw_m_s2_rthz = 4.8e-4             # or acc_vrw_m_s_rthr (m/s/sqrt(h)), _ug_rthz
    gyro_bias_sigma_rad_s = 3.5e-3         # turn-on σ; or gyro_bias_sigma_deg_h, _deg_s
    acc_bias_sigma_m_s2 = 0.157            # turn-on σ; or acc_bias_sigma_mg, _ug
    gyro_bias_instability_rad_s = 3.2e-5   # Gauss-Markov σ; or _deg_h, _deg_s
    acc_bias_instability_m_s2 = 9.8e-4     # Gauss-Markov σ; or _mg, _ug
    gyro_bias_corr_time_s = 3600.0         # optional (default 3600)
    acc_bias_corr_time_s = 3600.0          # optional (default 3600)
    gyro_scale_factor_sigma_ppm = 500.0    # optional: scale factor states (27 in all)
    acc_scale_factor_sigma_ppm = 500.0     # optional

    [gnss]                                 # optional table, every key optional
    std_pos_ned_m = [1.0, 1.0, 2.0]        # σ N, E, D where the GNSS file has none
    std_vel_ned_m_s = [0.1, 0.1, 0.1]
    antenna_lever_arm_body_m = [0.0, 0.0, 0.0]   # IMU -> antenna, body FRD (m)

    [init]                                 # optional table, every key optional
    std_att_rad = [0.01, 0.01, 0.02]       # roll, pitch, yaw σ; or std_att_deg
    std_vel_ned_m_s = [0.1, 0.1, 0.1]
    std_pos_ned_m = [1.0, 1.0, 2.0]
    gyro_bias_deg_h = [12.0, -8.5, 3.0]    # optional: lab-calibrated turn-on biases, with
    gyro_bias_std_deg_h = [1.0, 1.0, 1.0]  # their σ (or _rad_s, _deg_s keys)
    acc_bias_mg = [1.2, -0.4, 2.0]         # optional, with acc_bias_std_mg (or _m_s2, _ug)
    acc_bias_std_mg = [0.1, 0.1, 0.1]

    [filter]                               # optional table, every key optional
    max_imu_gap_s = 0.1                    # longer gaps between IMU samples: input error
    gate_probability = 0.9999              # χ² innovation gate

The turn-on σ of ``[imu]`` describes an IMU whose turn-on biases are unknown: the
filter estimates them from zero. ``[init]`` biases come from a laboratory calibration:
the filter starts from them with their σ instead. Each needs its σ key.

Conversions: 1 deg/sqrt(h) = (pi/180)/60 rad/s/sqrt(Hz); 1 m/s/sqrt(h) = 1/60
m/s^2/sqrt(Hz); 1 deg/h = (pi/180)/3600 rad/s; 1 mg = 9.80665e-3 m/s^2; 1 µg/sqrt(Hz) =
9.80665e-6 m/s^2/sqrt(Hz). Unknown tables
and keys are rejected (a typo must not silently fall back to a default), as are keys
given in two units. Values must be plausible (in SI units), as `InsConfig` requires of
every configuration (its spans, `kinsync.ins.config.FIELD_SPANS`, checked here first so
that a message names the key as written): noise terms and σ within 1e-12 to 1e6 (the
filter squares them and divides by them), correlation times within 1e-9 to 1e10 s,
``max_imu_gap_s`` within 1e-9 to 1e6 s, lever arm components within +-1000 m, scale
factor σ within 1e-6 to 1e6 ppm (leave the key out not to model them), calibrated
biases within +-10 rad/s and +-1000 m/s^2. `ins_config_to_toml_text` writes the SI keys
with ``repr`` floats, so a write/read round trip is exact.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kinsync._text import shown_value
from kinsync._validate import check_quantity
from kinsync.errors import InputError
from kinsync.ins.config import (
    BIAS_PAIRS,
    FIELD_SPANS,
    POSITIVE_FIELDS,
    SCALE_FACTOR_FIELDS,
    InsConfig,
)
from kinsync.io.atomic import atomic_write_text
from kinsync.io.mount_file import read_toml_text
from kinsync.mount import toml_document

__all__ = [
    "G0_M_S2",
    "ins_config_from_toml_text",
    "ins_config_to_toml_text",
    "read_ins_config",
    "write_ins_config",
]

G0_M_S2 = 9.80665
"""Standard gravity used for milli-g (m/s^2)."""

_DEG = math.pi / 180.0


def _rate_keys(stem: str) -> tuple[tuple[str, float], ...]:
    """The keys of an angular rate ``stem``: rad/s (SI), deg/h and deg/s."""
    return ((f"{stem}_rad_s", 1.0), (f"{stem}_deg_h", _DEG / 3600.0), (f"{stem}_deg_s", _DEG))


def _acceleration_keys(stem: str) -> tuple[tuple[str, float], ...]:
    """The keys of an acceleration ``stem``: m/s^2 (SI), mg and µg (``_ug``)."""
    return ((f"{stem}_m_s2", 1.0), (f"{stem}_mg", G0_M_S2 * 1e-3), (f"{stem}_ug", G0_M_S2 * 1e-6))


@dataclass(frozen=True)
class _Field:
    """One `InsConfig` field: its table, keys with factors to SI, vector or not."""

    attr: str
    table: str
    keys: tuple[tuple[str, float], ...]
    vector: bool = False
    required: bool = False


_FIELDS = (
    _Field(
        "gyro_arw_rad_s_rthz",
        "imu",
        (
            ("gyro_arw_rad_s_rthz", 1.0),
            ("gyro_arw_deg_rthr", _DEG / 60.0),
            ("gyro_arw_deg_s_rthz", _DEG),
        ),
        required=True,
    ),
    _Field(
        "acc_vrw_m_s2_rthz",
        "imu",
        (
            ("acc_vrw_m_s2_rthz", 1.0),
            ("acc_vrw_m_s_rthr", 1.0 / 60.0),
            ("acc_vrw_ug_rthz", G0_M_S2 * 1e-6),
        ),
        required=True,
    ),
    _Field("gyro_bias_sigma_rad_s", "imu", _rate_keys("gyro_bias_sigma"), required=True),
    _Field("acc_bias_sigma_m_s2", "imu", _acceleration_keys("acc_bias_sigma"), required=True),
    _Field(
        "gyro_bias_instability_rad_s", "imu", _rate_keys("gyro_bias_instability"), required=True
    ),
    _Field(
        "acc_bias_instability_m_s2",
        "imu",
        _acceleration_keys("acc_bias_instability"),
        required=True,
    ),
    _Field("gyro_bias_corr_time_s", "imu", (("gyro_bias_corr_time_s", 1.0),)),
    _Field("acc_bias_corr_time_s", "imu", (("acc_bias_corr_time_s", 1.0),)),
    _Field("gyro_scale_factor_sigma_ppm", "imu", (("gyro_scale_factor_sigma_ppm", 1.0),)),
    _Field("acc_scale_factor_sigma_ppm", "imu", (("acc_scale_factor_sigma_ppm", 1.0),)),
    _Field("gnss_std_pos_ned_m", "gnss", (("std_pos_ned_m", 1.0),), vector=True),
    _Field("gnss_std_vel_ned_m_s", "gnss", (("std_vel_ned_m_s", 1.0),), vector=True),
    _Field("antenna_lever_arm_body_m", "gnss", (("antenna_lever_arm_body_m", 1.0),), vector=True),
    _Field("init_std_att_rad", "init", (("std_att_rad", 1.0), ("std_att_deg", _DEG)), vector=True),
    _Field("init_std_vel_ned_m_s", "init", (("std_vel_ned_m_s", 1.0),), vector=True),
    _Field("init_std_pos_ned_m", "init", (("std_pos_ned_m", 1.0),), vector=True),
    _Field("init_gyro_bias_rad_s", "init", _rate_keys("gyro_bias"), vector=True),
    _Field("init_gyro_bias_std_rad_s", "init", _rate_keys("gyro_bias_std"), vector=True),
    _Field("init_acc_bias_m_s2", "init", _acceleration_keys("acc_bias"), vector=True),
    _Field("init_acc_bias_std_m_s2", "init", _acceleration_keys("acc_bias_std"), vector=True),
    _Field("max_imu_gap_s", "filter", (("max_imu_gap_s", 1.0),)),
    _Field("gate_probability", "filter", (("gate_probability", 1.0),)),
)

_TABLES = ("imu", "gnss", "init", "filter")


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        msg = f"{where}: expected a number, got {shown_value(value)}"
        raise InputError(msg)
    try:
        out = float(value)
    except OverflowError as err:
        msg = f"{where}: a {len(str(value))}-digit integer is too large (floats end near 1.8e308)"
        raise InputError(msg) from err
    if not math.isfinite(out):
        msg = f"{where}: must be finite, got {value!r}"
        raise InputError(msg)
    return out


def _value(value: object, field: _Field, factor: float, where: str) -> Any:
    """The value in SI units; a field that must be above 0 is checked as written."""

    def number(v: object, w: str) -> float:
        out = _number(v, w)
        if field.attr in POSITIVE_FIELDS and out <= 0.0:
            msg = f"{w}: must be above 0, got {v!r}"
            raise InputError(msg)
        return out * factor

    if not field.vector:
        return number(value, where)
    if not isinstance(value, list) or len(value) != 3:
        msg = f"{where}: expected a list of 3 numbers, got {shown_value(value)}"
        if isinstance(value, list):
            msg = f"{where}: expected a list of 3 numbers, got {len(value)}: {shown_value(value)}"
        raise InputError(msg)
    return tuple(number(v, f"{where}[{i}]") for i, v in enumerate(value))


def _check_pairs(written: dict[str, str], source: str) -> None:
    """A calibrated bias and its σ, given together (named as written)."""
    by_attr = {f.attr: f for f in _FIELDS}
    for value_attr, std_attr in BIAS_PAIRS:
        if (value_attr in written) == (std_attr in written):
            continue
        has, lacks = (value_attr, std_attr) if value_attr in written else (std_attr, value_attr)
        keys = " or ".join(k for k, _ in by_attr[lacks].keys)
        what = (
            "a calibrated turn-on bias needs its σ"
            if has == value_attr
            else ("a σ needs its calibrated bias")
        )
        msg = f"{source}: {written[has]} is given without {keys} in [init]: {what}; add it"
        raise InputError(msg)


def _check_spans(values: dict[str, Any], given: dict[str, str], source: str) -> None:
    """Every value given within its field's span, in SI units, named as written.

    ``values`` maps a field to its value in SI units, ``given`` to ``"[table] key"``
    as written. The check is `InsConfig`'s own (its `kinsync.ins.config.FIELD_SPANS`),
    run here first so that its message names the key rather than the field.
    """
    for attr, value in values.items():
        if attr in FIELD_SPANS:
            check_quantity(value, FIELD_SPANS[attr], f"{source}: {given[attr]}", " (in SI units)")


def ins_config_from_toml_text(text: str, source: str = "<string>") -> InsConfig:
    """Parse an INS configuration TOML document (schema in the module docstring).

    Parameters
    ----------
    text : str
        TOML document (a leading UTF-8 byte-order mark is accepted).
    source : str
        Name used in error messages (usually the file path).

    Returns
    -------
    InsConfig
        Values converted to SI.

    Raises
    ------
    InputError
        Malformed TOML (line and column), an unknown table or key, a quantity given in
        two units, a missing required ``[imu]`` key, a value of the wrong type or
        length, a value outside its plausible span (module docstring), a gate
        probability outside [0.9, 1).
    """
    doc = toml_document(text, source)
    unknown_tables = sorted(set(doc) - set(_TABLES))
    if unknown_tables:
        msg = (
            f"{source}: unknown table(s) or top-level key(s) {shown_value(unknown_tables)}; "
            f"expected tables {['[' + t + ']' for t in _TABLES]}"
        )
        raise InputError(msg)
    for name in _TABLES:
        table = doc.get(name, {})
        if not isinstance(table, Mapping):
            msg = f"{source}: {name} must be a table [{name}], got {shown_value(table)}"
            raise InputError(msg)
        known = [k for f in _FIELDS if f.table == name for k, _ in f.keys]
        unknown = sorted(set(table) - set(known))
        if unknown:
            got = shown_value(unknown)
            msg = f"{source}: unknown key(s) in [{name}]: {got}; expected one of {known}"
            raise InputError(msg)
    kwargs: dict[str, Any] = {}
    written: dict[str, str] = {}
    for field in _FIELDS:
        table = doc.get(field.table, {})
        given = [(k, f) for k, f in field.keys if k in table]
        if len(given) > 1:
            msg = (
                f"{source}: [{field.table}] gives {[k for k, _ in given]}, the same quantity "
                "in two units; keep one"
            )
            raise InputError(msg)
        if not given:
            if field.required:
                keys = " or ".join(k for k, _ in field.keys)
                msg = f"{source}: [{field.table}] needs {keys}"
                raise InputError(msg)
            continue
        key, factor = given[0]
        kwargs[field.attr] = _value(table[key], field, factor, f"{source}: [{field.table}] {key}")
        written[field.attr] = f"[{field.table}] {key}"
    _check_pairs(written, source)
    _check_spans(kwargs, written, source)
    try:
        config = InsConfig(**kwargs)
    except InputError as err:
        msg = f"{source}: {err}"
        raise InputError(msg) from err
    return config


def ins_config_to_toml_text(config: InsConfig) -> str:
    """Serialise a configuration to TOML with the SI keys (exact round trip)."""
    lines: list[str] = []
    for table in _TABLES:
        lines.append(f"[{table}]")
        for field in _FIELDS:
            if field.table != table:
                continue
            key = field.keys[0][0]
            value = getattr(config, field.attr)
            if value is None or (field.attr in SCALE_FACTOR_FIELDS and value == 0.0):
                continue  # not given: not modelled or not calibrated
            if field.vector:
                text = "[" + ", ".join(repr(float(v)) for v in value) + "]"
            else:
                text = repr(float(value))
            lines.append(f"{key} = {text}")
        lines.append("")
    return "\n".join(lines)


def read_ins_config(path: Path) -> InsConfig:
    """Read an INS configuration TOML file; errors name the file."""
    path = Path(path)
    text = read_toml_text(path, "INS configuration file")
    return ins_config_from_toml_text(text, source=str(path))


def write_ins_config(config: InsConfig, path: Path) -> None:
    """Write an INS configuration TOML file (SI keys) atomically."""
    atomic_write_text(Path(path), ins_config_to_toml_text(config))
