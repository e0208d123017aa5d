"""Where a folder output may go (`atomic_folder`, `check_output_location`), before any work.

``--out .`` used to run the whole command, then be refused naming the command's own
temporary folder: ``Path(".").parent`` is ``"."``, so the temporary folder was made inside
the output. A folder in a missing folder was created with its parents (and left behind,
empty, when the run stopped), contrary to "an output in a missing folder is refused at
once": the command-line check (`check_output_location`) refuses it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_folder, check_output_location


def _accept(_: Path) -> None:
    return None


@pytest.mark.parametrize("given", [".", ""])
@pytest.mark.parametrize("holds_files", [False, True], ids=["empty", "not-empty"])
def test_the_current_folder_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, given: str, holds_files: bool
) -> None:
    here = tmp_path / "here"
    here.mkdir()
    if holds_files:
        (here / "mine.txt").write_text("x")
    monkeypatch.chdir(here)
    worked = []
    with (
        pytest.raises(InputError, match=r"--out \.: is the current folder .*give a new folder"),
        atomic_folder(Path(given), _accept, "give another folder", option="--out"),
    ):
        worked.append(True)
    assert worked == []
    assert sorted(p.name for p in tmp_path.rglob("*")) == (
        ["here", "mine.txt"] if holds_files else ["here"]
    )
    with pytest.raises(InputError, match="is the current folder"):
        check_output_location(Path(given), "--out", folder=True)


def test_a_folder_above_the_current_one_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "a" / "b").mkdir(parents=True)
    monkeypatch.chdir(tmp_path / "a" / "b")
    with pytest.raises(InputError, match=r"--out \.\.: is a folder above the current one"):
        check_output_location(Path(".."), "--out", folder=True)


def test_a_relative_folder_is_written_beside_itself(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    with atomic_folder(Path("out"), _accept, "give another folder") as tmp:
        assert tmp.parent == tmp_path
        (tmp / "a.txt").write_text("x")
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == [
        "out",
        "out/a.txt",
    ]


def test_a_folder_in_a_missing_folder_is_refused(tmp_path: Path) -> None:
    target = tmp_path / "nope" / "deeper" / "x"
    with pytest.raises(InputError, match=r"--out .*x: output folder .*deeper does not exist"):
        check_output_location(target, "--out", folder=True)
    assert list(tmp_path.iterdir()) == []
    check_output_location(tmp_path / "new", "--out", folder=True)  # its parent exists
