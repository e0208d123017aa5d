"""Outputs published together: none replaces an earlier file until every one is complete."""

from __future__ import annotations

from pathlib import Path

import pytest

from kinsync.io.atomic import atomic_path, atomic_write_text, published_together


def _files(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(folder.iterdir())}


def test_complete_files_wait_for_the_end_of_the_block(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("old a")
    with published_together():
        atomic_write_text(tmp_path / "a.txt", "new a")
        atomic_write_text(tmp_path / "b.txt", "new b")
        assert (tmp_path / "a.txt").read_text() == "old a"
        assert not (tmp_path / "b.txt").exists()
    assert _files(tmp_path) == {"a.txt": "new a", "b.txt": "new b"}


def test_a_failure_after_one_file_is_complete_leaves_every_earlier_file(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "b.txt").write_text("old b")

    def write_both() -> None:
        with published_together():
            atomic_write_text(tmp_path / "a.txt", "new a")
            with atomic_path(tmp_path / "b.txt") as tmp:
                tmp.write_text("half of b")
                msg = "the second failed"
                raise RuntimeError(msg)

    with pytest.raises(RuntimeError, match="second"):
        write_both()
    assert _files(tmp_path) == {"a.txt": "old a", "b.txt": "old b"}  # no temporary left


def test_outside_the_block_a_file_is_published_at_once(tmp_path: Path) -> None:
    with published_together():
        pass
    atomic_write_text(tmp_path / "a.txt", "a")
    assert _files(tmp_path) == {"a.txt": "a"}
