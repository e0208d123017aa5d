"""An output given as a symbolic link is written to the file the link points to.

The temporary was renamed onto the link itself: the link became a regular file and
its target (or, for a dangling link, the file it names) never received the output,
with exit 0.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from kinsync.errors import InputError
from kinsync.io.atomic import (
    ProtectedInput,
    atomic_path,
    atomic_write_text,
    check_output_location,
    protected_inputs,
    published_together,
)


def _link(tmp_path: Path, target: str) -> Path:
    (tmp_path / "links").mkdir()
    link = tmp_path / "links" / "out.csv"
    link.symlink_to(target)
    return link


def test_the_target_of_a_link_receives_the_output(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "t.csv").write_text("old\n")
    link = _link(tmp_path, "../real/t.csv")
    atomic_write_text(link, "new\n")
    assert link.is_symlink()
    assert (tmp_path / "real" / "t.csv").read_text() == "new\n"
    assert [p.name for p in (tmp_path / "real").iterdir()] == ["t.csv"]  # no temporary
    assert [p.name for p in (tmp_path / "links").iterdir()] == ["out.csv"]


def test_a_dangling_link_creates_its_target(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    link = _link(tmp_path, str(tmp_path / "real" / "t.csv"))
    atomic_write_text(link, "new\n")
    assert link.is_symlink()
    assert (tmp_path / "real" / "t.csv").read_text() == "new\n"


def test_a_chain_of_links_is_followed_to_its_end(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "t.csv").write_text("old\n")
    (tmp_path / "middle.csv").symlink_to(tmp_path / "real" / "t.csv")
    link = _link(tmp_path, "../middle.csv")
    with published_together():
        atomic_write_text(link, "new\n")
        assert (tmp_path / "real" / "t.csv").read_text() == "old\n"
    assert link.is_symlink()
    assert (tmp_path / "middle.csv").is_symlink()
    assert (tmp_path / "real" / "t.csv").read_text() == "new\n"


def test_the_temporary_is_written_beside_the_target(tmp_path: Path) -> None:
    # so that the rename stays on one file system (the link may be on another)
    (tmp_path / "real").mkdir()
    link = _link(tmp_path, "../real/t.csv")
    with atomic_path(link) as tmp:
        assert tmp.parent.resolve() == (tmp_path / "real").resolve()
        tmp.write_text("new\n")


def test_a_link_to_a_missing_folder_is_refused_before_any_work(tmp_path: Path) -> None:
    link = _link(tmp_path, "../none/t.csv")
    with pytest.raises(InputError, match=r"--out .*out\.csv: output folder .*none does not exist"):
        check_output_location(link, "--out")
    with pytest.raises(InputError, match="does not exist"), atomic_path(link):
        pass
    assert link.is_symlink()


def test_a_link_to_an_input_is_still_refused(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    source = tmp_path / "real" / "t.csv"
    source.write_text("input\n")
    link = _link(tmp_path, "../real/t.csv")
    with (
        protected_inputs([ProtectedInput(source, f"--in {source}")]),
        pytest.raises(InputError, match="is the input --in"),
    ):
        atomic_write_text(link, "new\n")
    assert source.read_text() == "input\n"
    assert link.is_symlink()
