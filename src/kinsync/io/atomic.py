"""Write files so that they appear only when complete."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from kinsync.errors import InputError

__all__ = ["atomic_path", "atomic_write_bytes", "atomic_write_text"]


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left untouched.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path()
    if not parent.is_dir():
        msg = f"{path}: output folder {parent} does not exist; create it first"
        raise InputError(msg)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=parent)
    os.close(fd)
    tmp = Path(tmp_name)
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    try:
        yield tmp
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` through a temporary file and an atomic rename."""
    atomic_write_bytes(path, text.encode("utf-8"))


def output_folder(path: Path, hint: str, *, create: bool = True, option: str = "") -> Path:
    """Check that ``path`` can be an output folder (absent or a folder); create it.

    Parameters
    ----------
    path : Path
        The folder.
    hint : str
        What to do instead, ending the error message (e.g. "give a folder for the
        simulation").
    create : bool
        Create the folder (and its parents) when it is missing.
    option : str
        Command-line option naming the folder in the message (e.g. "--out"), if any.

    Raises
    ------
    InputError
        ``path`` exists and is not a folder.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        prefix = f"{option} " if option else ""
        msg = f"{prefix}{path}: exists and is not a folder; {hint}"
        raise InputError(msg)
    if create:
        path.mkdir(parents=True, exist_ok=True)
    return path
