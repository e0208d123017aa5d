"""Figures where matplotlib's own folder cannot be written (a read-only HOME or root).

matplotlib printed two lines of its own on stderr and, where no temporary folder could
be made either (TMPDIR unwritable too), its import failed: ``OSError: Matplotlib
requires access to a writable cache directory``, exit 1, after ``--model-out`` had been
written and without naming it. An unwritable folder is made here as a path below a
regular file (no chmod: root could write anyway), the temporary folder likewise.
"""

from __future__ import annotations

import os
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import pytest

from kinsync.errors import InputError, KinsyncWarning
from kinsync.report._mpl_folder import prepare_matplotlib_folder

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


@pytest.fixture
def unwritable_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """matplotlib's folders below a regular file; matplotlib not imported yet."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder\n")
    monkeypatch.setenv("HOME", str(blocker))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(blocker / "config"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker / "cache"))
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)  # restored (unset) afterwards
    monkeypatch.delitem(sys.modules, "matplotlib", raising=False)
    if not sys.platform.startswith(("linux", "freebsd")):
        pytest.skip("matplotlib's XDG folders are used on Linux and FreeBSD only")
    return blocker


def test_a_writable_folder_is_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MPLCONFIGDIR", str(tmp_path / "mpl"))
    monkeypatch.delitem(sys.modules, "matplotlib", raising=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prepare_matplotlib_folder()
    assert os.environ["MPLCONFIGDIR"] == str(tmp_path / "mpl")


def test_an_unwritable_folder_gives_a_temporary_one_and_one_warning(
    unwritable_home: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        prepare_matplotlib_folder()
    chosen = Path(os.environ["MPLCONFIGDIR"])
    assert chosen.parent == temporary
    assert chosen.is_dir()
    assert [w.category for w in seen] == [KinsyncWarning]
    assert str(unwritable_home / "config" / "matplotlib") in str(seen[0].message)
    assert "set MPLCONFIGDIR to a writable folder" in str(seen[0].message)


def test_an_unwritable_mplconfigdir_is_named(
    unwritable_home: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MPLCONFIGDIR", str(unwritable_home / "mpl"))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with pytest.warns(KinsyncWarning, match=r"MPLCONFIGDIR \(.*mpl\) cannot be written"):
        prepare_matplotlib_folder()
    assert Path(os.environ["MPLCONFIGDIR"]).parent == tmp_path


def test_no_temporary_folder_either_is_an_input_error(
    unwritable_home: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(unwritable_home / "tmp"))
    with pytest.raises(InputError, match=r"set MPLCONFIGDIR \(or TMPDIR\) to a writable folder"):
        prepare_matplotlib_folder()
    assert "MPLCONFIGDIR" not in os.environ


@pytest.fixture(scope="module")
def clock_logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from kinsync.cli import main  # noqa: PLC0415

    folder = tmp_path_factory.mktemp("clock") / "logs"
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "clock", "--out", str(folder), "--seed", "1", "--duration-s", "60"])
    assert exc.value.code == 0
    return folder


@pytest.mark.usefixtures("unwritable_home")
def test_a_figure_is_refused_before_any_output_is_written(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    clock_logs: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "file" / "tmp"))
    out = tmp_path / "out"
    out.mkdir()
    logs = ["--pps", str(clock_logs / "pps.csv"), "--nmea", str(clock_logs / "nmea.csv")]
    argv = ["clock", "fit", *logs, "--model-out", str(out / "m.json")]
    result = run_cli([*argv, "--figure", str(out / "r.png")])
    assert_one_line_error(*result, "set MPLCONFIGDIR (or TMPDIR) to a writable folder")
    assert list(out.iterdir()) == []
