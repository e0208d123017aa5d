"""Tests of kinsync.mount and kinsync.io.mount_file (the mount TOML schema)."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from kinsync.errors import InputError
from kinsync.frames import euler_rpy_to_matrix
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.mount import (
    MAX_ANGLE_DEG,
    MAX_LATENCY_S,
    MAX_LEVER_ARM_M,
    Mount,
    mount_from_toml_text,
    mount_to_toml_text,
)


def _within(limit: float) -> st.SearchStrategy[float]:
    """Floats a mount file may hold: subnormals, -0.0 and the bound itself included."""
    return st.floats(min_value=-limit, max_value=limit, allow_nan=False)


file_mounts = st.builds(
    Mount,
    lever_arm_body_m=st.tuples(*[_within(MAX_LEVER_ARM_M)] * 3),
    boresight_rpy_deg=st.tuples(*[_within(MAX_ANGLE_DEG)] * 3),
    antenna_lever_arm_body_m=st.tuples(*[_within(MAX_LEVER_ARM_M)] * 3),
    latency_s=_within(MAX_LATENCY_S),
)
"""Any mount the container takes: it refuses what a mount file may not hold."""

SCHEMA_DEFAULT = (
    "[mount]\n"
    "lever_arm_body_m = [0.0, 0.0, 0.0]\n"
    "boresight_rpy_deg = [0.0, 0.0, 0.0]\n"
    "antenna_lever_arm_body_m = [0.0, 0.0, 0.0]\n"
    "latency_s = 0.0\n"
)

VALID_TEXT = (
    "[mount]\n"
    "lever_arm_body_m = [0.12, -0.3, 1.5]\n"
    "boresight_rpy_deg = [0.5, -0.25, 90.0]\n"
    "antenna_lever_arm_body_m = [-0.8, 0.0, -1.2]\n"
    "latency_s = 0.0123\n"
)


def _bits(m: Mount) -> list[str]:
    """Every float of a mount as its exact hex form (distinguishes -0.0 from 0.0)."""
    values = [*m.lever_arm_body_m, *m.boresight_rpy_deg, *m.antenna_lever_arm_body_m]
    return [float(v).hex() for v in [*values, m.latency_s]]


# ---------------------------------------------------------------- round trips
# This module draws values up to the refusal bounds; the warnings for those beyond the
# warning bounds are tested in tests/io/test_mount_file.py.
pytestmark = pytest.mark.filterwarnings("ignore:.*is beyond:kinsync.errors.KinsyncWarning")


@settings(max_examples=200, deadline=None)
@given(mount=file_mounts)
def test_toml_text_round_trip_is_exact(mount: Mount) -> None:
    back = mount_from_toml_text(mount_to_toml_text(mount))
    assert back == mount
    assert _bits(back) == _bits(mount)


@settings(
    max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(mount=file_mounts)
def test_file_round_trip_is_exact(mount: Mount, tmp_path: Path) -> None:
    path = tmp_path / "mount.toml"
    write_mount(mount, path)
    back = read_mount(path)
    assert _bits(back) == _bits(mount)
    assert path.read_text(encoding="utf-8") == mount_to_toml_text(mount)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mount.toml"]  # no temporary left


@settings(max_examples=50, deadline=None)
@given(mount=file_mounts)
def test_any_mount_is_written_exactly(mount: Mount) -> None:
    """The text of any mount the container takes keeps every bit."""
    doc = tomllib.loads(mount_to_toml_text(mount))["mount"]
    keys = ("lever_arm_body_m", "boresight_rpy_deg", "antenna_lever_arm_body_m")
    values = [*(v for k in keys for v in doc[k]), doc["latency_s"]]
    assert [float(v).hex() for v in values] == _bits(mount)


@pytest.mark.parametrize(
    "value", [5e-324, 2.2250738585072014e-308, 1e-300, -0.0, 0.1, 1.0 / 3.0, 9.999999999999998]
)
def test_extreme_values_round_trip(value: float) -> None:
    mount = Mount((value, -value, 1.0), (value, 0.0, -value), (0.0, value, 0.0), value)
    text = mount_to_toml_text(mount)
    assert _bits(mount_from_toml_text(text)) == _bits(mount)


def test_values_at_the_bounds_round_trip() -> None:
    mount = Mount(
        (MAX_LEVER_ARM_M, -MAX_LEVER_ARM_M, 0.0),
        (-MAX_ANGLE_DEG, MAX_ANGLE_DEG, 0.0),
        (0.0, 0.0, -MAX_LEVER_ARM_M),
        -MAX_LATENCY_S,
        profiler_azimuth_deg=MAX_ANGLE_DEG,
    )
    assert mount_from_toml_text(mount_to_toml_text(mount)) == mount


def test_text_layout_is_the_schema() -> None:
    assert mount_to_toml_text(Mount()) == SCHEMA_DEFAULT
    mount = Mount((0.12, -0.3, 1.5), (0.5, -0.25, 90.0), (-0.8, 0.0, -1.2), 0.0123)
    assert mount_to_toml_text(mount) == VALID_TEXT
    assert mount_from_toml_text(VALID_TEXT) == mount
    doc = tomllib.loads(mount_to_toml_text(mount))
    assert list(doc) == ["mount"]
    assert list(doc["mount"]) == [
        "lever_arm_body_m",
        "boresight_rpy_deg",
        "antenna_lever_arm_body_m",
        "latency_s",
    ]


def test_integers_and_missing_vectors_are_accepted() -> None:
    mount = mount_from_toml_text("[mount]\nlever_arm_body_m = [1, 2, -3]\nlatency_s = 0\n")
    assert mount.lever_arm_body_m == (1.0, 2.0, -3.0)
    assert all(isinstance(v, float) for v in mount.lever_arm_body_m)
    assert isinstance(mount.latency_s, float)
    assert mount.boresight_rpy_deg == (0.0, 0.0, 0.0)
    assert mount.antenna_lever_arm_body_m == (0.0, 0.0, 0.0)
    assert mount_from_toml_text("[mount]\nlatency_s = 0.0\n") == Mount()


# ---------------------------------------------------------------- the container


def test_defaults_are_zero() -> None:
    mount = Mount()
    assert mount.lever_arm_body_m == (0.0, 0.0, 0.0)
    assert mount.boresight_rpy_deg == (0.0, 0.0, 0.0)
    assert mount.antenna_lever_arm_body_m == (0.0, 0.0, 0.0)
    assert mount.latency_s == 0.0
    assert_array_equal(mount.R_scanner_to_body, np.eye(3))
    assert_array_equal(mount.lever_arm_body_m_array, np.zeros(3))


@settings(max_examples=100, deadline=None)
@given(rpy=st.tuples(*[st.floats(min_value=-360.0, max_value=360.0, allow_nan=False)] * 3))
def test_R_scanner_to_body_is_euler_of_radians(rpy: tuple[float, float, float]) -> None:
    mount = Mount(boresight_rpy_deg=rpy)
    expected = euler_rpy_to_matrix(*(math.radians(a) for a in rpy))
    assert_allclose(mount.R_scanner_to_body, expected, rtol=0, atol=1e-15)
    assert mount.R_scanner_to_body.shape == (3, 3)


def test_R_scanner_to_body_known_yaw() -> None:
    R = Mount(boresight_rpy_deg=(0.0, 0.0, 90.0)).R_scanner_to_body
    assert_allclose(R @ np.array([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)


def test_mount_is_frozen() -> None:
    mount = Mount(latency_s=0.01)
    with pytest.raises(dataclasses.FrozenInstanceError):
        mount.latency_s = 0.02  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        mount.lever_arm_body_m = (1.0, 2.0, 3.0)  # type: ignore[misc]
    changed = mount.with_latency(0.02)
    assert changed.latency_s == 0.02
    assert mount.latency_s == 0.01
    assert changed.lever_arm_body_m == mount.lever_arm_body_m


def test_constructor_normalises_and_validates() -> None:
    mount = Mount(lever_arm_body_m=np.array([1, 2, 3]), latency_s=np.float32(0.5))  # type: ignore[arg-type]
    assert mount.lever_arm_body_m == (1.0, 2.0, 3.0)
    assert isinstance(mount.lever_arm_body_m, tuple)
    assert type(mount.latency_s) is float
    with pytest.raises(InputError, match="lever_arm_body_m"):
        Mount(lever_arm_body_m=(1.0, 2.0))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="latency_s"):
        Mount(latency_s=math.nan)
    with pytest.raises(InputError, match="boresight_rpy_deg"):
        Mount(boresight_rpy_deg=(0.0, math.inf, 0.0))
    with pytest.raises(InputError, match="latency_s"):
        Mount(latency_s="0.1")  # type: ignore[arg-type]


# ---------------------------------------------------------------- bad input


def test_malformed_toml_names_source(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="malformed TOML") as info:
        mount_from_toml_text("[mount\nlatency_s = 0.1\n", source="calib/mount.toml")
    assert "calib/mount.toml" in str(info.value)
    path = tmp_path / "broken.toml"
    path.write_text("[mount]\nlatency_s = = 0.1\n", encoding="utf-8")
    with pytest.raises(InputError, match="malformed TOML") as info:
        read_mount(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[mount]\nlatency_s = 0.1\nlatency_s = 0.2\n", "line 3, column 16: a key given twice"),
        ("[mount]\nlatency_s = 0.1\nlatency_s = 0.2", "(latency_s); keep one of the two"),
        ("[mount]\nlatency_s = 0.1\n[mount]\n", "table [mount] is declared twice"),
        ("[uncertainty.correlation]\n[uncertainty.correlation]\n", "[uncertainty.correlation]"),
        ("[mount]\nu = {a = 1}\nu.b = 2\n", "mount.u was written as an inline table"),
        ("[mount]\nlatency_s = 0.1\n[mount # again\n", "header '[mount' lacks its closing ']'"),
    ],
)
def test_a_name_given_twice_is_said_in_plain_words(text: str, words: str) -> None:
    """tomllib's "Cannot overwrite a value" names no key: the message names it."""
    with pytest.raises(InputError) as info:
        mount_from_toml_text(text, source="m.toml")
    message = str(info.value)
    assert message.startswith("m.toml: line ")
    assert words in message
    assert "Cannot" not in message


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("latency_s = 0.1\n", r"\[mount\]"),
        ("", r"\[mount\]"),
        ("mount = 3\n", r"\[mount\]"),
        ("[mounts]\nlatency_s = 0.1\n", r"\[mount\]"),
        ("[mount]\nlever_arm_body = [0.0, 0.0, 0.0]\n", "lever_arm_body"),
        ("[mount]\nlatency_s = 0.1\nlatency_ms = 5\n", "latency_ms"),
        ("[mount]\nlever_arm_body_m = [0.1, 0.2]\n", "lever_arm_body_m"),
        ("[mount]\nboresight_rpy_deg = [0.1, 0.2, 0.3, 0.4]\n", "boresight_rpy_deg"),
        ("[mount]\nlever_arm_body_m = 0.5\n", "lever_arm_body_m"),
        ('[mount]\nlatency_s = "0.01"\n', "latency_s"),
        ('[mount]\nantenna_lever_arm_body_m = "0 0 1"\n', "antenna_lever_arm_body_m"),
        ('[mount]\nboresight_rpy_deg = [0.0, "1", 0.0]\n', "boresight_rpy_deg"),
        ("[mount]\nlatency_s = true\n", "latency_s"),
        ("[mount]\nlever_arm_body_m = [true, 0.0, 0.0]\n", "lever_arm_body_m"),
        ("[mount]\nlatency_s = nan\n", "latency_s"),
        ("[mount]\nlatency_s = -inf\n", "latency_s"),
        ("[mount]\nlever_arm_body_m = [0.0, nan, 0.0]\n", "lever_arm_body_m"),
        ("[mount]\nlatency_s = 0.1\n[extra]\nx = 1\n", "extra"),
        ("[mount]\nlatency_s = 0.1\n[mount.sub]\nx = 1\n", "sub"),
    ],
    ids=[
        "no-table",
        "empty",
        "mount-not-a-table",
        "misspelt-table",
        "typo-key",
        "unknown-key",
        "two-numbers",
        "four-numbers",
        "scalar-for-vector",
        "string-latency",
        "string-vector",
        "string-in-vector",
        "bool-latency",
        "bool-in-vector",
        "nan-latency",
        "inf-latency",
        "nan-in-vector",
        "extra-table",
        "sub-table",
    ],
)
def test_bad_documents_raise_input_error(text: str, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern) as info:
        mount_from_toml_text(text, source="cfg/mount.toml")
    assert str(info.value).startswith("cfg/mount.toml: ")


def test_bad_file_names_file(tmp_path: Path) -> None:
    path = tmp_path / "mount.toml"
    path.write_text("[mount]\nlatency_s = nan\n", encoding="utf-8")
    with pytest.raises(InputError, match="latency_s") as info:
        read_mount(path)
    assert str(path) in str(info.value)


def test_missing_file_names_file(tmp_path: Path) -> None:
    path = tmp_path / "absent" / "mount.toml"
    with pytest.raises(InputError, match="not found") as info:
        read_mount(path)
    assert str(path) in str(info.value)


def test_write_into_missing_folder_raises(tmp_path: Path) -> None:
    path = tmp_path / "absent" / "mount.toml"
    with pytest.raises(InputError, match="does not exist"):
        write_mount(Mount(), path)
    assert not path.exists()


# --- [profiler] section (2D profile scanners, SPEC section 4) ---


@given(az=st.floats(-360.0, 360.0, allow_nan=False))
def test_profiler_azimuth_round_trips_exactly(az: float) -> None:
    mount = Mount(lever_arm_body_m=(0.1, 0.2, 0.3), profiler_azimuth_deg=az)
    text = mount_to_toml_text(mount)
    assert "[profiler]" in text
    assert mount_from_toml_text(text) == mount


def test_no_profiler_table_means_none_and_no_section() -> None:
    mount = mount_from_toml_text("[mount]\nlatency_s = 0.001\n")
    assert mount.profiler_azimuth_deg is None
    assert "[profiler]" not in mount_to_toml_text(mount)


def test_profile_to_scanner_follows_spec_formula() -> None:
    phi = np.array([0.0, np.pi / 2, -np.pi / 6])
    r = np.array([2.0, 3.0, 4.0])
    xyz = Mount().profile_to_scanner(angle_rad=phi, range_m=r)
    # azimuth 0: (0, r sin phi, r cos phi)
    np.testing.assert_allclose(xyz[0], [0.0, 0.0, 2.0], atol=1e-15)
    np.testing.assert_allclose(xyz[1], [0.0, 3.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(xyz[2], [0.0, -2.0, 4.0 * np.cos(np.pi / 6)], atol=1e-15)
    # azimuth 90 deg rotates +Y onto -X (Rz(90) (0, 1, 0) = (-1, 0, 0))
    xyz90 = Mount(profiler_azimuth_deg=90.0).profile_to_scanner(angle_rad=phi[1:2], range_m=r[1:2])
    np.testing.assert_allclose(xyz90[0], [-3.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(xyz, axis=1), r)


@pytest.mark.parametrize(
    ("phi", "r", "pattern"),
    [
        (
            [0.1, 0.2],
            [1.0, 2.0, 3.0],
            r"range_m must be 1-D arrays of one length, got shapes \(2,\) and \(3,\)",
        ),
        ([[0.1, 0.2]], [[1.0, 2.0]], "angle_rad and range_m must be 1-D"),
        ([0.1, 30.0], [1.0, 2.0], r"angle_rad\[1\] = 30\.0 is not a finite angle within one turn"),
        ([0.1, math.nan], [1.0, 2.0], r"angle_rad\[1\] = nan"),
        ([0.1, 0.2], [1.0, -2.0], r"range_m\[1\] = -2\.0: a range is a finite number >= 0"),
        ([0.1, 0.2], [math.inf, 2.0], r"range_m\[0\] = inf"),
        (["a"], [1.0], "angle_rad and range_m must be numbers"),
    ],
)
def test_profile_to_scanner_refuses_what_profile_points_to_scanner_refuses(
    phi: object, r: object, pattern: str
) -> None:
    with pytest.raises(InputError, match=r"profile_to_scanner: .*" + pattern):
        Mount().profile_to_scanner(angle_rad=phi, range_m=r)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("[mount]\n[profiler]\nazimuth = 3.0\n", "unknown key.*profiler"),
        ("[mount]\n[profiler]\nazimuth_deg = 'x'\n", "azimuth_deg"),
        ("[mount]\nprofiler = 3\n", "unknown key"),
        # an empty [profiler] table was read as azimuth 0 deg (exit 0)
        ("[mount]\n[profiler]\n", r"\[profiler\] has no azimuth_deg"),
    ],
)
def test_bad_profiler_section(text: str, pattern: str) -> None:
    with pytest.raises(InputError, match=pattern):
        mount_from_toml_text(text)


@pytest.mark.parametrize(
    ("kwargs", "fragments"),
    [
        ({"latency_s": 400.0}, ["mount latency_s = 400.0 s", "+-10 s"]),
        ({"latency_s": -10.5}, ["mount latency_s = -10.5 s"]),
        ({"lever_arm_body_m": (150.0, 0.0, 1500.0)}, ["mount lever_arm_body_m[2] = 1500.0 m"]),
        ({"antenna_lever_arm_body_m": (0.0, -1e6, 0.0)}, ["antenna_lever_arm_body_m[1]"]),
        ({"boresight_rpy_deg": (720.0, 0.0, 0.0)}, ["mount boresight_rpy_deg[0] = 720.0 deg"]),
        ({"profiler_azimuth_deg": -400.0}, ["[profiler] azimuth_deg = -400.0 deg"]),
    ],
)
def test_container_refuses_what_a_mount_file_may_not_hold(
    kwargs: dict[str, object], fragments: list[str]
) -> None:
    """One check for a mount built in Python and one read from a file (the reader's bounds)."""
    with pytest.raises(InputError) as info:
        Mount(**kwargs)  # type: ignore[arg-type]
    for fragment in fragments:
        assert fragment in str(info.value)
    with pytest.raises(InputError, match="beyond"):
        dataclasses.replace(Mount(), **kwargs)  # type: ignore[arg-type]


_HUGE = "[" + ", ".join(["1.0"] * 200_000) + "]"


@pytest.mark.parametrize(
    ("text", "words"),
    [
        # The whole list (a 1 MB line) was repeated.
        (f"[mount]\nlever_arm_body_m = {_HUGE}\n", "expected a list of 3 numbers, got 200000: ["),
        (f"[mount]\nlatency_s = {_HUGE}\n", "expected a number of seconds, got ["),
        (f"[mount]\nlatency_s = 0.1\n[uncertainty]\nlatency_s = {_HUGE}\n", "got ["),
        (f'[mount]\nlever_arm_body_m = "{"x" * 200_000}"\n', "got 'xxx"),
        (f"[mount]\n{'k' * 200_000} = 1\n", "unknown key(s) in [mount]: ['kkk"),
    ],
)
def test_a_long_value_is_cut_short_in_the_message(text: str, words: str) -> None:
    with pytest.raises(InputError, match=re.escape(words)) as info:
        mount_from_toml_text(text, source="m.toml")
    assert len(str(info.value)) < 400
    assert "..." in str(info.value)
