"""Reading kinsync's TOML files: byte-order marks, syntax errors, missing and absurd values.

Every TOML file kinsync reads (mounts, INS configurations) goes through
`kinsync.mount.toml_document` (and, from a file, `kinsync.io.mount_file.read_toml_text`):
a UTF-8 byte-order mark is accepted, a syntax error names the file, line and column,
and a mount must give its latency explicitly and within bounds.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from kinsync.errors import InputError, KinsyncWarning
from kinsync.io.ins_config import ins_config_from_toml_text, read_ins_config
from kinsync.io.mount_file import MAX_TOML_BYTES, read_mount, read_toml_text, write_mount
from kinsync.mount import (
    MAX_ANGLE_DEG,
    MAX_LATENCY_S,
    MAX_LEVER_ARM_M,
    Mount,
    mount_from_toml_text,
    mount_to_toml_text,
    toml_document,
)

BOM = "\ufeff"
GOOD_MOUNT = (
    "[mount]\n"
    "lever_arm_body_m = [0.12, -0.3, 1.5]\n"
    "boresight_rpy_deg = [0.5, -0.25, 90.0]\n"
    "antenna_lever_arm_body_m = [-0.8, 0.0, -1.2]\n"
    "latency_s = 0.0123\n"
)
GOOD_INS = (
    "[imu]\n"
    "gyro_arw_rad_s_rthz = 1e-4\n"
    "acc_vrw_m_s2_rthz = 1e-3\n"
    "gyro_bias_sigma_rad_s = 1e-3\n"
    "acc_bias_sigma_m_s2 = 0.01\n"
    "gyro_bias_instability_rad_s = 1e-5\n"
    "acc_bias_instability_m_s2 = 1e-4\n"
)
REPO = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- byte-order mark


def test_bom_is_accepted_in_a_mount_file(tmp_path: Path) -> None:
    path = tmp_path / "mount.toml"
    path.write_bytes((BOM + GOOD_MOUNT).encode("utf-8"))
    assert read_mount(path) == mount_from_toml_text(GOOD_MOUNT)
    assert read_mount(path).latency_s == 0.0123


def test_bom_is_accepted_in_an_ins_configuration(tmp_path: Path) -> None:
    path = tmp_path / "ins.toml"
    path.write_bytes((BOM + GOOD_INS).encode("utf-8"))
    assert read_ins_config(path) == ins_config_from_toml_text(GOOD_INS)


def test_bom_with_windows_line_ends(tmp_path: Path) -> None:
    path = tmp_path / "mount.toml"
    path.write_bytes((BOM + GOOD_MOUNT).replace("\n", "\r\n").encode("utf-8"))
    assert read_mount(path).boresight_rpy_deg == (0.5, -0.25, 90.0)


@pytest.mark.parametrize("name", ["mount.toml", "ins.toml"])
def test_lone_carriage_return_line_ends_are_read(tmp_path: Path, name: str) -> None:
    """Accepted by every CSV reader, they gave "malformed TOML line 1, column 8"."""
    path = tmp_path / name
    text = GOOD_MOUNT if name == "mount.toml" else GOOD_INS
    path.write_bytes(text.replace("\n", "\r").encode("utf-8"))
    if name == "mount.toml":
        assert read_mount(path) == mount_from_toml_text(GOOD_MOUNT)
    else:
        assert read_ins_config(path) == ins_config_from_toml_text(GOOD_INS)


def test_only_a_leading_bom_is_dropped() -> None:
    """A BOM inside a string is data; one between statements is a syntax error."""
    assert toml_document(BOM + 'a = "x\ufeffy"\n', "t.toml") == {"a": "x\ufeffy"}
    with pytest.raises(InputError, match=r"t\.toml: line 2, column 1: malformed TOML"):
        toml_document("a = 1\n\ufeffb = 2\n", "t.toml")


# ---------------------------------------------------------------- syntax errors


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("[mount]\nlatency_s = = 0.1\n", "line 2, column 13"),
        ("[mount\nlatency_s = 0.1\n", "line 1, column 7"),
        ("[mount]\nlever_arm_body_m = [0.1, 0.2\n", "line 3, column 1 (end of document)"),
        ("[mount]\nlatency_s = 0.1", None),
        ('[mount]\nname = "open', "line 2, column 13 (end of document)"),
        (BOM + "[mount]\nlatency_s = 0.1 0.2\n", "line 2, column 17"),
    ],
)
def test_syntax_errors_name_file_line_and_column(
    tmp_path: Path, text: str, where: str | None
) -> None:
    path = tmp_path / "mount.toml"
    path.write_text(text, encoding="utf-8")
    if where is None:  # valid TOML: no error
        assert read_mount(path).latency_s == 0.1
        return
    with pytest.raises(InputError) as info:
        read_mount(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {where}: malformed TOML: ")
    assert "\n" not in message


def test_ins_configuration_syntax_error_names_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "ins.toml"
    path.write_text(GOOD_INS + "[filter\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"line 8, column 8: malformed TOML") as info:
        read_ins_config(path)
    assert str(info.value).startswith(f"{path}: ")


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("a = " + "1" * 5000 + "\n", "number too long"),
        ("a = " + "[" * 5000 + "]" * 5000 + "\n", "nested too deeply"),
    ],
)
def test_parser_limits_are_input_errors(text: str, fragment: str) -> None:
    with pytest.raises(InputError, match=fragment) as info:
        toml_document(text, "deep.toml")
    assert str(info.value).startswith("deep.toml: ")


# ---------------------------------------------------------------- the file itself


def test_file_problems_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="mount file not found"):
        read_mount(tmp_path / "none.toml")
    with pytest.raises(InputError, match="cannot read mount file"):
        read_mount(tmp_path)  # a directory
    utf16 = tmp_path / "utf16.toml"
    utf16.write_bytes(GOOD_MOUNT.encode("utf-16"))
    with pytest.raises(InputError, match=r"not UTF-8 text \(byte 0.*save it as UTF-8"):
        read_mount(utf16)
    big = tmp_path / "big.toml"
    with big.open("wb") as fh:  # sparse: no disk used
        fh.truncate(MAX_TOML_BYTES + 1)
    with pytest.raises(InputError, match="too large for a INS configuration file"):
        read_ins_config(big)
    exact = tmp_path / "exact.toml"
    exact.write_bytes((GOOD_MOUNT + "#" * (MAX_TOML_BYTES - len(GOOD_MOUNT))).encode())
    assert read_mount(exact).latency_s == 0.0123


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_an_endless_device_is_refused_not_read_forever() -> None:
    with pytest.raises(InputError, match=r"not a regular file \(a device or a pipe\)"):
        read_toml_text(Path("/dev/zero"), "mount file")


# ---------------------------------------------------------------- latency_s required


@pytest.mark.parametrize(
    "text",
    [
        "[mount]\n",
        "[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\nboresight_rpy_deg = [0.0, 0.0, 90.0]\n",
        "[mount]\nlever_arm_body_m = [0.1, 0.2, 0.3]\n[profiler]\nazimuth_deg = 10.0\n",
    ],
)
def test_missing_latency_is_an_error_saying_what_to_write(tmp_path: Path, text: str) -> None:
    path = tmp_path / "mount.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as info:
        read_mount(path)
    message = str(info.value)
    assert message.startswith(f"{path}: [mount] latency_s is missing")
    assert "latency_s = 0.0" in message


def test_explicit_zero_latency_is_fine() -> None:
    assert mount_from_toml_text("[mount]\nlatency_s = 0.0\n") == Mount()
    assert mount_from_toml_text("[mount]\nlatency_s = 0\n").latency_s == 0.0


def test_every_mount_kinsync_writes_carries_its_latency(tmp_path: Path) -> None:
    """`write_mount` (what every simulator and the calibration use) writes latency_s."""
    for mount in (Mount(), Mount(latency_s=-0.002, profiler_azimuth_deg=12.5)):
        text = mount_to_toml_text(mount)
        assert "\nlatency_s = " in text
        path = tmp_path / "m.toml"
        write_mount(mount, path)
        assert read_mount(path) == mount


def test_simulators_write_mount_files_that_read_back(tmp_path: Path) -> None:
    from kinsync.sim.rotating_table import (  # noqa: PLC0415 - a simulator, loaded on use
        simulate_rotating_table,
        write_simulation,
    )
    from kinsync.sim.table_config import RotatingTableConfig  # noqa: PLC0415

    config = RotatingTableConfig(rates_deg_s=(10.0,), passes=1, boresight_rpy_deg=(0.2, -0.1, 3))
    write_simulation(simulate_rotating_table(config), tmp_path / "table", raw=True)
    text = (tmp_path / "table" / "raw" / "mount.toml").read_text(encoding="utf-8")
    assert "\nlatency_s = " in text
    mount = read_mount(tmp_path / "table" / "raw" / "mount.toml")
    assert mount.boresight_rpy_deg == (0.2, -0.1, 3.0)


def test_mount_files_in_the_repository_read() -> None:
    """Mount TOML files shipped with kinsync (none besides what the writers make, today)."""
    found = [
        p
        for p in REPO.rglob("*.toml")
        if ".venv" not in p.parts and "[mount]" in p.read_text(encoding="utf-8", errors="ignore")
    ]
    for path in found:
        read_mount(path)
    for path in REPO.glob("configs/*.toml"):
        read_ins_config(path)


# ---------------------------------------------------------------- absurd values


@pytest.mark.parametrize(
    ("line", "fragments"),
    [
        ("latency_s = 1e308", ["latency_s = 1e+308 s", f"+-{MAX_LATENCY_S:g} s"]),
        ("latency_s = -18.0", ["latency_s = -18.0 s", "time-scale"]),
        ("latency_s = 10.000001", ["latency_s"]),
        ("lever_arm_body_m = [0.0, 1e308, 0.0]", ["lever_arm_body_m[1]", f"{MAX_LEVER_ARM_M:g}"]),
        ("antenna_lever_arm_body_m = [0.0, 0.0, -1500]", ["antenna_lever_arm_body_m[2]"]),
        ("boresight_rpy_deg = [0.0, 0.0, 720.0]", ["boresight_rpy_deg[2]", "360"]),
        ("boresight_rpy_deg = [-1e300, 0.0, 0.0]", ["boresight_rpy_deg[0]", "360"]),
        ("latency_s = 1" + "0" * 400, ["latency_s", "401-digit integer"]),
        ("lever_arm_body_m = [0, 0, 1" + "0" * 400 + "]", ["lever_arm_body_m", "digit"]),
        ("latency_s = inf", ["latency_s", "finite"]),
        ("lever_arm_body_m = [0.0, -inf, 0.0]", ["lever_arm_body_m", "finite"]),
    ],
)
def test_absurd_values_are_refused_at_read_time(line: str, fragments: list[str]) -> None:
    key = line.split(" =", maxsplit=1)[0]
    text = "[mount]\n" + line + "\n" + ("" if key == "latency_s" else "latency_s = 0.0\n")
    with pytest.raises(InputError) as info:
        mount_from_toml_text(text, source="cal/mount.toml")
    message = str(info.value)
    assert message.startswith("cal/mount.toml: ")
    for fragment in fragments:
        assert fragment in message, message
    assert "repeated" not in message


def test_profiler_azimuth_is_bounded_too() -> None:
    with pytest.raises(InputError, match=r"\[profiler\] azimuth_deg = 1000.0 deg"):
        mount_from_toml_text("[mount]\nlatency_s = 0.0\n[profiler]\nazimuth_deg = 1000.0\n")
    with pytest.raises(InputError, match="digit integer"):
        mount_from_toml_text("[mount]\nlatency_s = 0.0\n[profiler]\nazimuth_deg = 1" + "0" * 400)


def test_values_at_the_bounds_are_accepted() -> None:
    text = (
        "[mount]\n"
        f"lever_arm_body_m = [{MAX_LEVER_ARM_M}, {-MAX_LEVER_ARM_M}, 0.0]\n"
        f"boresight_rpy_deg = [{-MAX_ANGLE_DEG}, {MAX_ANGLE_DEG}, 0.0]\n"
        f"latency_s = {MAX_LATENCY_S}\n"
    )
    with pytest.warns(KinsyncWarning):
        mount = mount_from_toml_text(text)
    assert mount.latency_s == MAX_LATENCY_S


@pytest.mark.parametrize(
    ("line", "fragments"),
    [
        ("latency_s = 5", ["latency_s = 5.0 s", "in seconds", "5.0 ms would be 0.005"]),
        ("latency_s = -1.5", ["latency_s = -1.5 s", "+-1 s"]),
        ("lever_arm_body_m = [0.0, 150.0, 0.0]", ["lever_arm_body_m[1] = 150.0 m", "metres"]),
        ("antenna_lever_arm_body_m = [-120.0, 0.0, 0.0]", ["antenna_lever_arm_body_m[0]"]),
    ],
)
def test_unit_slips_are_read_with_a_warning(line: str, fragments: list[str]) -> None:
    # 5 (meant as ms) was georeferenced as 5 s without a word, as was 150 cm written 150.
    key = line.split(" =", maxsplit=1)[0]
    text = "[mount]\n" + line + "\n" + ("" if key == "latency_s" else "latency_s = 0.0\n")
    with pytest.warns(KinsyncWarning) as caught:
        mount_from_toml_text(text, source="cal/mount.toml")
    assert len(caught) == 1
    message = str(caught[0].message)
    assert message.startswith("cal/mount.toml: [mount] ")
    for fragment in fragments:
        assert fragment in message, message


def test_usual_values_give_no_warning() -> None:
    text = (
        "[mount]\nlever_arm_body_m = [99.0, -99.0, 3.0]\n"
        "antenna_lever_arm_body_m = [0.0, 0.0, -100.0]\nlatency_s = -0.999\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mount_from_toml_text(text)


def test_ins_configuration_huge_integer_is_an_input_error() -> None:
    text = GOOD_INS.replace("acc_bias_sigma_m_s2 = 0.01", "acc_bias_sigma_m_s2 = 1" + "0" * 400)
    with pytest.raises(InputError, match=r"acc_bias_sigma_m_s2: a 401-digit integer"):
        ins_config_from_toml_text(text, source="ins.toml")


def test_a_mount_measured_from_another_says_so_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A calibrated mount file begins with what produced it and its source's own header
    (a serial number was dropped); calibrated again from it, the header does not nest
    (each run wrapped the last one's header in its own) and names the folder (the
    command's paths are relative)."""
    from kinsync.io.provenance import set_command, software  # noqa: PLC0415

    monkeypatch.chdir(tmp_path)
    first = tmp_path / "vehicle.toml"
    write_mount(Mount(lever_arm_body_m=(0.1, 0.0, 0.2)), first)
    first.write_text("# VX-12, S/N 4711\n\n" + first.read_text(encoding="utf-8"))
    second, third = tmp_path / "cal1.toml", tmp_path / "cal2.toml"
    try:
        set_command(["calibrate", "mount", "--mount", "vehicle.toml", "--out", "cal1.toml"])
        write_mount(read_mount(first), second, derived_from=first)
        set_command(["calibrate", "mount", "--mount", "cal1.toml", "--out", "cal2.toml"])
        write_mount(read_mount(second), third, derived_from=second)
    finally:
        set_command(None)
    text = third.read_text(encoding="utf-8")
    head = [line for line in text.splitlines() if line.startswith("#")]
    assert head == [
        f"# written by {software()} at 2023-11-14T22:13:20Z",
        f"# from {second}",
        "# command: kinsync calibrate mount --mount cal1.toml --out cal2.toml",
        f"# in {tmp_path}",
        "# cal1.toml's header:",
        "# VX-12, S/N 4711",
    ]
    assert read_mount(third) == read_mount(first)
    plain = tmp_path / "plain.toml"
    write_mount(read_mount(first), plain)  # no source given: no header at all
    assert not plain.read_text(encoding="utf-8").startswith("#")
