"""What produced a result: the software that made it, the command, and when.

An auditor who signs a calibration or a georeferenced cloud must be able to say which
code produced it and how: "kinsync 0.1.0" alone was the same for every commit of the
project, while two commits in a row gave a roll of 0.284 and 0.290 deg from the same
lines. So the software is named with its version and, run from a git checkout (an
editable install or ``PYTHONPATH``), the commit (``+g`` and 8 hex digits, ``.dirty``
when tracked files differ from it, ``.unknown`` when git cannot say):
``kinsync 0.1.0+g36905f60.dirty``, a PEP 440 local version. An installed wheel gives
its version alone.

The time is UTC now, or ``SOURCE_DATE_EPOCH`` (seconds since 1970-01-01 UTC, the
reproducible-builds convention) when set, so the same inputs give the same outputs on
any day. The command is what the command-line program was run with (`set_command`),
``None`` in a Python session.
"""

from __future__ import annotations

import datetime as dt
import functools
import os
import shlex
import subprocess
from collections.abc import Sequence
from pathlib import Path

from kinsync import __version__
from kinsync.errors import InputError

__all__ = [
    "command_line",
    "command_line_without",
    "run_record",
    "run_time_utc",
    "set_command",
    "software",
    "software_version",
]

_SHA_DIGITS = 8  # "kinsync 0.1.0+g<8>.unknown" fits a LAS header's 32 bytes
_GIT_TIMEOUT_S = 5.0
_COMMAND: list[str | None] = [None]


def _git_dir(repo: Path) -> Path | None:
    """The git directory of a checkout at ``repo`` (``.git`` or a worktree's), or None."""
    dot_git = repo / ".git"
    if dot_git.is_dir():
        return dot_git
    if dot_git.is_file():  # a worktree or submodule: "gitdir: <path>"
        text = dot_git.read_text(encoding="utf-8", errors="replace").strip()
        if text.startswith("gitdir:"):
            target = Path(text.removeprefix("gitdir:").strip())
            return target if target.is_absolute() else (repo / target).resolve()
    return None


def _head_commit(git_dir: Path) -> str | None:
    """The commit HEAD names (40 hex digits), read from the files; None if unreadable."""
    try:
        head = (git_dir / "HEAD").read_text(encoding="utf-8").strip()
        if not head.startswith("ref:"):
            return head or None
        ref = head.removeprefix("ref:").strip()
        common = git_dir
        if (git_dir / "commondir").is_file():  # a worktree keeps refs in the main one
            common = (git_dir / (git_dir / "commondir").read_text().strip()).resolve()
        for base in (git_dir, common):
            loose = base / ref
            if loose.is_file():
                return loose.read_text(encoding="utf-8").strip() or None
        packed = common / "packed-refs"
        if packed.is_file():
            for line in packed.read_text(encoding="utf-8").splitlines():
                sha, _, name = line.partition(" ")
                if name.strip() == ref:
                    return sha
    except OSError:
        return None
    return None


def _dirty(repo: Path) -> bool | None:
    """Whether tracked files differ from HEAD (``git status``); None when git cannot say.

    Git missing, too slow (`_GIT_TIMEOUT_S`) or refusing (a ``safe.directory`` check):
    a clean checkout is not claimed. ``--no-optional-locks``: the user's index is never
    locked by it.
    """
    argv = ["git", "--no-optional-locks", "-C", str(repo), "status", "--porcelain"]
    try:
        done = subprocess.run(  # noqa: S603 - fixed arguments, no shell
            [*argv, "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=_GIT_TIMEOUT_S,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if done.returncode != 0:
        return None
    return bool(done.stdout.strip())


@functools.cache
def software_version() -> str:
    """Kinsync's version, with the commit when it runs from a git checkout.

    Returns
    -------
    str
        ``"0.1.0"`` from an installed package; ``"0.1.0+g<8 hex>"`` from a checkout
        (``".dirty"`` appended when tracked files were changed since that commit,
        ``".unknown"`` when git could not say).
    """
    package = Path(__file__).resolve().parent.parent  # <repo>/src/kinsync/io/provenance.py
    repo = package.parent.parent
    if package.parent.name != "src" or not (repo / "pyproject.toml").is_file():
        return __version__
    git_dir = _git_dir(repo)
    sha = None if git_dir is None else _head_commit(git_dir)
    if sha is None or len(sha) < _SHA_DIGITS:
        return __version__
    state = {True: ".dirty", False: "", None: ".unknown"}[_dirty(repo)]
    return f"{__version__}+g{sha[:_SHA_DIGITS]}{state}"


def software() -> str:
    """``"kinsync <software_version()>"``: what wrote an output."""
    return f"kinsync {software_version()}"


def run_time_utc() -> dt.datetime:
    """The time an output is stamped with: now (UTC), or ``SOURCE_DATE_EPOCH``'s.

    Returns
    -------
    datetime.datetime
        Timezone-aware (UTC), to the second.

    Raises
    ------
    InputError
        ``SOURCE_DATE_EPOCH`` set to something other than a whole number of seconds
        within the years 1970-9999.
    """
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is None or epoch == "":
        return dt.datetime.now(dt.UTC).replace(microsecond=0)
    try:
        return dt.datetime.fromtimestamp(int(epoch), dt.UTC)
    except (ValueError, OverflowError, OSError):
        msg = (
            f"SOURCE_DATE_EPOCH={epoch!r}: the date of kinsync's outputs is taken from it "
            "and it must be a whole number of seconds since 1970-01-01 UTC (e.g. "
            "$(date +%s)); unset it to use the current time"
        )
        raise InputError(msg) from None


def set_command(argv: Sequence[str] | None) -> None:
    """Record the command line the program runs (the CLI calls it; None forgets it).

    Parameters
    ----------
    argv : sequence of str or None
        The arguments after the program's name.
    """
    _COMMAND[0] = None if argv is None else shlex.join(["kinsync", *argv])


def command_line() -> str | None:
    """The command line recorded by `set_command` (shell-quoted), or None."""
    return _COMMAND[0]


def command_line_without(options: Sequence[str], flags: Sequence[str] = ()) -> str | None:
    """The recorded command line less ``options`` with their values, and ``flags``.

    For a record inside an output that must not depend on how the work was run (the
    scheduler, the workers, the chunk size, whether a JSON summary was printed), only on
    what was computed.

    Parameters
    ----------
    options : sequence of str
        Long options that take one value (``--workers 4`` or ``--workers=4``).
    flags : sequence of str
        Long options that take none (``--json``).

    Returns
    -------
    str or None
        The command, shell-quoted; None when none was recorded (`set_command`).
    """
    command = _COMMAND[0]
    if command is None:
        return None
    kept: list[str] = []
    skip = False
    for word in shlex.split(command):
        if skip:
            skip = False
            continue
        name = word.split("=", 1)[0]
        if name in options:
            skip = "=" not in word
        elif word not in flags:
            kept.append(word)
    return shlex.join(kept)


def run_record() -> dict[str, str | None]:
    """What produced an output: software, command (None from Python), UTC time.

    Returns
    -------
    dict
        ``{"software": "kinsync 0.1.0+g...", "command": "kinsync georef ...",
        "utc": "2026-11-28T11:30:42Z"}``.
    """
    return {
        "software": software(),
        "command": command_line(),
        "utc": run_time_utc().strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
