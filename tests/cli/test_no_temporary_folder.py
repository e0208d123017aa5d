"""``--scheduler processes`` where no temporary folder can be written (a read-only root).

The pool's context file goes to the temporary folder: ``tempfile`` raised
``FileNotFoundError: No usable temporary directory found in ['/tmp', ...]``, an internal
error (exit 1). The temporary folder is made unusable here by ``tempfile`` itself
failing as it does then (files written elsewhere, the outputs' own temporaries, work).
"""

from __future__ import annotations

import errno
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from tests._georef_scan import scan_columns, write_laz, write_trajectory

from kinsync.errors import InputError
from kinsync.pipelines import schedulers

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


def _no_temporary_folder(monkeypatch: pytest.MonkeyPatch, code: int = errno.ENOENT) -> None:
    real = tempfile.mkstemp

    def mkstemp(*args: Any, **kwargs: Any) -> tuple[int, str]:
        if kwargs.get("dir") is None:  # the system's temporary folder
            raise FileNotFoundError(code, "No usable temporary directory found in ['/tmp']")
        return real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)


def test_the_context_file_says_to_set_tmpdir(monkeypatch: pytest.MonkeyPatch) -> None:
    _no_temporary_folder(monkeypatch)
    with pytest.raises(InputError, match=r"no writable one found\); set TMPDIR to a writable"):
        schedulers._write_context({})  # type: ignore[arg-type]


def test_an_unwritable_tmpdir_is_said_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "file").write_text("not a folder\n")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "file" / "tmp"))
    with pytest.raises(InputError, match=r"\(Not a directory\); set TMPDIR to a writable folder"):
        schedulers._write_context({})  # type: ignore[arg-type]


def test_georef_with_processes_stops_in_one_line(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    write_trajectory(tmp_path / "traj.csv", 4.0)
    cols = scan_columns(100, 3.0, 1)
    cols["t_s"] = cols["t_s"] + 0.6
    write_laz(cols, tmp_path / "scan.laz")
    (tmp_path / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    _no_temporary_folder(monkeypatch)
    argv = ["georef", "--points", str(tmp_path / "scan.laz"), "--trajectory"]
    argv += [str(tmp_path / "traj.csv"), "--mount", str(tmp_path / "m.toml")]
    argv += ["--scheduler", "processes", "--workers", "2", "--out", str(tmp_path / "o.laz")]
    code, out, err = run_cli(argv)
    assert_one_line_error(code, out, err, "--scheduler processes", "set TMPDIR")
    assert not (tmp_path / "o.laz").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]
