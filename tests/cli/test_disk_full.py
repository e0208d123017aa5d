"""A full disk (or disk quota) while an output is written: one line naming it, exit 2.

It used to end as ``kinsync: internal error: OSError: [Errno 28] No space left on
device`` (exit 1), naming no file. The writers here are made to fail as a full disk
makes them (after some bytes), so no small file system is needed.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests._georef_scan import scan_columns, write_trajectory

from kinsync.errors import InputError
from kinsync.io import atomic
from kinsync.io.atomic import atomic_folder, atomic_path, atomic_write_text
from kinsync.io.points import TableChunkWriter
from kinsync.io.table_writer import TableChunkWriter as TableWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


def _full(code: int = errno.ENOSPC) -> OSError:
    return OSError(code, os.strerror(code))


def _trajectory_csv(path: Path) -> Path:
    t = 1.3e9 + np.arange(500) * 0.01
    s = t - 1.3e9
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.0 * s])
    write_trajectory_csv(Trajectory.from_euler(t, 0 * s, 0 * s, 0.3 + 0 * s, lat_lon_h=llh), path)
    return path


def _no_leftovers(folder: Path, out: Path) -> None:
    assert not out.exists()
    assert not [p for p in folder.iterdir() if p.name.startswith(f".{out.name}.")]


@pytest.mark.parametrize(
    ("code", "words"), [(errno.ENOSPC, "disk is full"), (errno.EDQUOT, "quota")]
)
def test_a_table_export_on_a_full_disk_names_the_output(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    code: int,
    words: str,
) -> None:
    traj = _trajectory_csv(tmp_path / "traj.csv")
    out = tmp_path / "t.csv"
    write = TableWriter._write_table

    def fill_then_fail(self: Any, table: Any) -> None:
        write(self, table)
        raise _full(code)

    monkeypatch.setattr(TableWriter, "_write_table", fill_then_fail)
    result = run_cli(["trajectory", "export", str(traj), "--out", str(out)])
    assert_one_line_error(*result, f"--out {out}", words, "free space")
    assert "internal error" not in result[2]
    _no_leftovers(tmp_path, out)


def test_a_georef_output_on_a_full_disk_names_the_output(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    write_trajectory(tmp_path / "traj.csv", 4.0)
    cols = scan_columns(300, 3.0, 1)
    cols["t_s"] = cols["t_s"][cols["t_s"] >= 1.3e9]
    n = cols["t_s"].size
    with TableChunkWriter(tmp_path / "p.csv") as w:
        w.write({k: v[-n:] for k, v in cols.items()})
    (tmp_path / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    out = tmp_path / "g10.csv"
    write = TableWriter._write_table

    def fill_then_fail(self: Any, table: Any) -> None:
        write(self, table)
        raise _full()

    monkeypatch.setattr(TableWriter, "_write_table", fill_then_fail)
    argv = ["georef", "--points", str(tmp_path / "p.csv"), "--trajectory"]
    argv += [str(tmp_path / "traj.csv"), "--mount", str(tmp_path / "m.toml"), "--out", str(out)]
    code, stdout, err = run_cli(argv)
    last = err.splitlines()[-1]  # stage lines (no terminal here) come before it
    assert_one_line_error(code, stdout, last + "\n", f"--out {out}", "disk is full")
    _no_leftovers(tmp_path, out)


def test_a_text_output_on_a_full_disk_names_the_output(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    traj = _trajectory_csv(tmp_path / "traj.csv")
    out = tmp_path / "line.geojson"

    def fail(self: Path, data: str, **_: Any) -> int:
        with self.open("w") as f:
            f.write(data[:10])
        raise _full()

    monkeypatch.setattr(Path, "write_text", fail)
    result = run_cli(["trajectory", "export", str(traj), "--out", str(out)])
    assert_one_line_error(*result, f"--out {out}", "disk is full")
    _no_leftovers(tmp_path, out)


def _write_on_a_full_disk(out: Path) -> None:
    with atomic_path(out) as tmp:
        tmp.write_bytes(b"partial")
        raise _full()


def test_atomic_path_turns_a_full_disk_into_an_input_error(tmp_path: Path) -> None:
    out = tmp_path / "a.bin"
    with pytest.raises(InputError, match=r"a\.bin: the disk is full"):
        _write_on_a_full_disk(out)
    _no_leftovers(tmp_path, out)


def _folder_on_a_full_disk(final: Path) -> None:
    def nothing(_: Path) -> None:
        return None

    with (
        atomic_folder(final, nothing, "give a folder") as tmp,
        atomic.named_outputs([("--out", final)]),
    ):
        atomic_write_text(tmp / "a.txt", "x")
        _write_on_a_full_disk(tmp / "b.txt")


def test_a_file_inside_a_folder_output_is_named_in_the_output_folder(tmp_path: Path) -> None:
    final = tmp_path / "run"
    with pytest.raises(InputError) as info:
        _folder_on_a_full_disk(final)
    assert str(info.value).startswith(f"{final / 'b.txt'}: the disk is full")
    assert not final.exists()


def test_a_file_inside_nested_folder_outputs_is_named_in_the_outer_output(
    tmp_path: Path,
) -> None:
    """The demo writes its passes folder inside its own: the message named the hidden
    temporary folder (``demo/.passes.123.x.part/pass_007.laz``)."""
    final = tmp_path / "demo"

    def nothing(_: Path) -> None:
        return None

    def nested() -> None:
        with (
            atomic_folder(final, nothing, "give a folder") as tmp,
            atomic_folder(tmp / "passes", nothing, "give a folder") as inner,
        ):
            _write_on_a_full_disk(inner / "pass_007.laz")

    with pytest.raises(InputError) as info:
        nested()
    assert str(info.value).startswith(f"{final / 'passes' / 'pass_007.laz'}: the disk is full")
    assert not final.exists()


def test_a_full_disk_elsewhere_is_one_line_too(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A full disk met outside an output (a temporary file) still says so, exit 2."""
    traj = _trajectory_csv(tmp_path / "traj.csv")
    import kinsync.pipelines.trajectory_export as export  # noqa: PLC0415

    def fail(*_: Any, **__: Any) -> None:
        err = _full()
        err.filename = "/tmp/scratch"
        raise err

    monkeypatch.setattr(export, "read_trajectory_file", fail)
    result = run_cli(["trajectory", "export", str(traj), "--out", str(tmp_path / "t.csv")])
    assert_one_line_error(*result, "/tmp/scratch", "disk is full")
