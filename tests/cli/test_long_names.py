"""File names at and beyond the file system's limit (255 bytes on most).

A name over the limit, given as an input (``mount check NAME.toml``, ``--points``) or an
output (``--out``), ended in ``internal error: OSError: [Errno 36] File name too long``
(exit 1). An output name of 226 to 255 bytes, which the file system takes, was refused
("cannot write in the folder . (File name too long)"): its hidden temporary repeats
the name and adds about 22 bytes. A georef output near the limit was written, then the
run failed looking for an earlier rejected file whose name would be over it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest
from tests._georef_scan import scan_columns, write_laz, write_trajectory

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, atomic_write_text

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    try:
        name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        name_max = 255
    if name_max != 255:
        pytest.skip(f"the temporary folder's file system takes names of {name_max} bytes")
    return tmp_path


def test_an_input_name_over_the_limit_is_named(
    run_cli: RunCli, assert_one_line_error: OneLineError, folder: Path
) -> None:
    mount = folder / ("m" * 260 + ".toml")
    code, out, err = run_cli(["mount", "check", str(mount)])
    assert_one_line_error(code, out, err, str(mount), "265 bytes long", "give a shorter name")


def test_an_option_over_the_limit_is_named_by_its_option(
    run_cli: RunCli, assert_one_line_error: OneLineError, folder: Path
) -> None:
    write_trajectory(folder / "traj.csv", 2.0)
    (folder / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    points = folder / ("p" * 300 + ".laz")
    base = ["georef", "--trajectory", str(folder / "traj.csv"), "--mount", str(folder / "m.toml")]
    code, out, err = run_cli([*base, "--points", str(points), "--out", str(folder / "o.laz")])
    assert_one_line_error(code, out, err, f"--points {points}: the name ppp", "give a shorter")
    write_laz(scan_columns(50, 1.0, 1), folder / "scan.laz")
    long_out = folder / ("o" * 256 + ".csv")
    code, out, err = run_cli([*base, "--points", str(folder / "scan.laz"), "--out", str(long_out)])
    assert_one_line_error(code, out, err, f"--out {long_out}: the name ooo", "260 bytes long")
    assert sorted(p.name for p in folder.iterdir()) == ["m.toml", "scan.laz", "traj.csv"]


@pytest.mark.parametrize("length", [240, 250, 255])
def test_an_output_name_the_file_system_takes_is_written(folder: Path, length: int) -> None:
    out = folder / ("é" * ((length - 4) // 2) + "x" * ((length - 4) % 2) + ".csv")
    assert len(os.fsencode(out.name)) == length
    atomic_write_text(out, "a\n")
    atomic_write_text(out, "b\n")  # replacing it too
    assert [p.name for p in folder.iterdir()] == [out.name]
    assert out.read_text() == "b\n"


def test_temporaries_of_two_long_names_differ(folder: Path) -> None:
    a, b = folder / ("a" * 250 + "1"), folder / ("a" * 250 + "2")
    with atomic_path(a) as tmp_a, atomic_path(b) as tmp_b:
        assert len(os.fsencode(tmp_a.name)) <= 255
        assert tmp_a.name.split(".")[1] != tmp_b.name.split(".")[1]
        tmp_a.write_text("a")
        tmp_b.write_text("b")
    assert (a.read_text(), b.read_text()) == ("a", "b")


def test_atomic_path_refuses_a_name_over_the_limit(folder: Path) -> None:
    with (
        pytest.raises(InputError, match="is 300 bytes long, more than file systems allow"),
        atomic_path(folder / ("n" * 300)),
    ):
        pass


def test_a_georef_output_at_the_limit_is_written(run_cli: RunCli, folder: Path) -> None:
    write_trajectory(folder / "traj.csv", 4.0)
    cols = scan_columns(50, 3.0, 1)
    cols["t_s"] = cols["t_s"] + 0.6  # none rejected: this run writes no rejected file
    write_laz(cols, folder / "scan.laz")
    (folder / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    out = folder / ("g" * 251 + ".csv")  # an earlier run's rejects: NAME.rejected.laz
    argv = ["georef", "--points", str(folder / "scan.laz"), "--trajectory"]
    argv += [str(folder / "traj.csv"), "--mount", str(folder / "m.toml"), "--out", str(out)]
    code, _, err = run_cli(argv)
    assert code == 0, err
    assert out.is_file()
