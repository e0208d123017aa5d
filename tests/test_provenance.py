"""What produced a result: the software with its commit, the command, the time."""

from __future__ import annotations

import datetime as dt
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import kinsync
from kinsync.errors import InputError
from kinsync.io import provenance
from kinsync.io.provenance import (
    _dirty,
    _git_dir,
    _head_commit,
    command_line_without,
    run_record,
    run_time_utc,
    set_command,
    software,
    software_version,
)

ROOT = Path(__file__).resolve().parents[1]


def test_the_software_names_the_version_and_a_checkout_s_commit() -> None:
    """Every commit said 'kinsync 0.1.0' though two in a row calibrated differently."""
    text = software()
    assert text == f"kinsync {software_version()}"
    assert software_version().startswith(kinsync.__version__)
    git_dir = _git_dir(ROOT)
    if git_dir is None:  # tests run from an installed copy or an exported tree
        assert software_version() == kinsync.__version__
        return
    sha = _head_commit(git_dir)
    assert sha is not None
    assert re.fullmatch(r"[0-9a-f]{40}", sha)
    if shutil.which("git") is not None:
        head = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "HEAD"],
            check=False,
            capture_output=True,
            text=True,
        )
        if head.returncode == 0:
            assert sha == head.stdout.strip()
    assert re.fullmatch(
        re.escape(kinsync.__version__) + r"\+g" + sha[:8] + r"(\.dirty|\.unknown)?",
        software_version(),
    )
    assert len(text) <= 32  # a LAS header's Generating Software


def _repo(tmp_path: Path, *, packed: bool) -> tuple[Path, str]:
    repo = tmp_path / "repo"
    git = repo / ".git"
    (git / "refs" / "heads").mkdir(parents=True)
    sha = "0123456789abcdef0123456789abcdef01234567"
    (git / "HEAD").write_text("ref: refs/heads/main\n")
    if packed:
        (git / "packed-refs").write_text(f"# pack-refs with: peeled\n{sha} refs/heads/main\n")
    else:
        (git / "refs" / "heads" / "main").write_text(sha + "\n")
    return repo, sha


@pytest.mark.parametrize("packed", [False, True])
def test_the_commit_is_read_from_loose_or_packed_refs(tmp_path: Path, packed: bool) -> None:
    repo, sha = _repo(tmp_path, packed=packed)
    git_dir = _git_dir(repo)
    assert git_dir == repo / ".git"
    assert _head_commit(git_dir) == sha


def test_a_worktree_s_git_file_and_a_detached_head(tmp_path: Path) -> None:
    _, sha = _repo(tmp_path, packed=False)
    tree = tmp_path / "tree"
    (tree / "gitdir").mkdir(parents=True)
    (tree / ".git").write_text(f"gitdir: {tree / 'gitdir'}\n")
    (tree / "gitdir" / "HEAD").write_text(sha + "\n")  # detached
    git_dir = _git_dir(tree)
    assert git_dir == tree / "gitdir"
    assert _head_commit(git_dir) == sha
    assert _git_dir(tmp_path / "nothing") is None
    (tree / "gitdir" / "HEAD").unlink()
    assert _head_commit(git_dir) is None
    assert _dirty(tmp_path / "nothing") is None  # git cannot say: not claimed clean


def test_the_time_is_now_or_source_date_epoch(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1785000000")
    assert run_time_utc() == dt.datetime(2026, 7, 25, 17, 20, tzinfo=dt.UTC)
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    before = dt.datetime.now(dt.UTC).replace(microsecond=0)
    assert before <= run_time_utc() <= dt.datetime.now(dt.UTC)
    for bad in ("soon", "1.5", "-1e30"):
        monkeypatch.setenv("SOURCE_DATE_EPOCH", bad)
        with pytest.raises(InputError, match=r"SOURCE_DATE_EPOCH=.*whole number of seconds"):
            run_time_utc()


def test_the_record_holds_the_command_only_when_one_was_run() -> None:
    try:
        set_command(None)
        assert run_record()["command"] is None
        set_command(["georef", "--points", "a b.las", "--json"])
        record = run_record()
        assert record["command"] == "kinsync georef --points 'a b.las' --json"
        assert record["software"] == software()
        assert record["utc"] == "2023-11-14T22:13:20Z"  # tests' SOURCE_DATE_EPOCH
    finally:
        set_command(None)
    assert provenance.command_line() is None


def test_the_command_without_options_leaves_out_their_values_and_flags() -> None:
    try:
        set_command(None)
        assert command_line_without(["--workers"], ["--json"]) is None
        argv = ["georef", "--workers", "4", "--json", "--points", "a b.las", "--chunk-points=7"]
        set_command([*argv, "--json"])
        kept = command_line_without(["--workers", "--chunk-points"], ["--json"])
        assert kept == "kinsync georef --points 'a b.las'"
        # A flag's name as another option's value is that value.
        set_command(["georef", "--workers", "--json", "--out", "o.laz"])
        assert command_line_without(["--workers"], ["--json"]) == "kinsync georef --out o.laz"
    finally:
        set_command(None)


def test_a_checkout_git_cannot_read_is_not_claimed_clean(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without git (or when it refused the folder) the version read 0.1.0+g<sha>, a clean
    checkout, though tracked files had been changed."""
    repo, sha = _repo(tmp_path, packed=False)
    monkeypatch.setenv("PATH", str(tmp_path / "no-git-here"))
    assert _dirty(repo) is None
    software_version.cache_clear()
    monkeypatch.setattr(provenance, "__file__", str(repo / "src" / "kinsync" / "io" / "p.py"))
    (repo / "pyproject.toml").write_text("")
    try:
        assert software_version() == f"{kinsync.__version__}+g{sha[:8]}.unknown"
    finally:
        software_version.cache_clear()
