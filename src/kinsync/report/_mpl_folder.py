"""A writable folder for matplotlib's settings and font cache, chosen before it is imported.

matplotlib writes its settings and font cache into ``MPLCONFIGDIR``, else (Linux)
``~/.config/matplotlib`` and ``~/.cache/matplotlib``. Where that folder cannot be
written (a read-only ``HOME`` or root file system), matplotlib prints two lines of its
own on stderr and makes a temporary folder; where the temporary folder cannot be made
either, its import fails (``OSError: Matplotlib requires access to a writable cache
directory``), which ended a command with an internal error after it had written its
other outputs. `prepare_matplotlib_folder` makes the same choice first: a temporary
folder, said in one kinsync warning, or a one-line `InputError` saying to set
``MPLCONFIGDIR`` (or ``TMPDIR``) when even that fails, before any output is written.
"""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from kinsync.errors import InputError, KinsyncWarning

__all__ = ["prepare_matplotlib_folder"]


def _folders() -> list[Path] | None:
    """The folders matplotlib will write to (None: unknown, or home not found).

    Mirrors ``matplotlib._get_config_or_cache_dir``: ``MPLCONFIGDIR`` when set, else
    the XDG folders on Linux and FreeBSD, else ``~/.matplotlib``.
    """
    given = os.environ.get("MPLCONFIGDIR")
    if given:
        return [Path(given)]
    if sys.platform == "win32":
        return []  # matplotlib's own choice (%LOCALAPPDATA%): left to it
    try:
        home = Path.home()
    except RuntimeError:
        return None
    if sys.platform.startswith(("linux", "freebsd")):
        config = os.environ.get("XDG_CONFIG_HOME") or str(home / ".config")
        cache = os.environ.get("XDG_CACHE_HOME") or str(home / ".cache")
        return [Path(config, "matplotlib"), Path(cache, "matplotlib")]
    return [home / ".matplotlib"]


def _writable(folder: Path) -> bool:
    """Whether matplotlib would accept ``folder`` (created if missing), as it tests it."""
    try:
        folder = folder.resolve()
        folder.mkdir(parents=True, exist_ok=True)
    except (OSError, RuntimeError):
        return False
    return folder.is_dir() and os.access(folder, os.W_OK)


def prepare_matplotlib_folder() -> None:
    """Point ``MPLCONFIGDIR`` at a new temporary folder when matplotlib's is not writable.

    Does nothing once matplotlib is imported (it has chosen its folder) or when its
    folders are writable. Otherwise the temporary folder is removed when the process
    exits and a `KinsyncWarning` says which folder could not be written.

    Raises
    ------
    InputError
        matplotlib's folder is not writable and no temporary folder can be made either
        (``TMPDIR``, ``/tmp``, ``/var/tmp``, ... all unwritable).
    """
    if "matplotlib" in sys.modules:
        return
    folders = _folders()
    bad = next((f for f in folders if not _writable(f)), None) if folders is not None else None
    if folders is not None and bad is None:
        return
    if bad is None:
        where = "in the home folder (which is not found)"
    else:
        where = f"MPLCONFIGDIR ({bad})" if os.environ.get("MPLCONFIGDIR") else str(bad)
    try:
        tmp = tempfile.mkdtemp(prefix="kinsync-matplotlib-")
    except OSError:
        msg = (
            f"figures need a writable folder for matplotlib's settings and font cache: "
            f"{where} cannot be written, nor can a temporary folder be made; set "
            "MPLCONFIGDIR (or TMPDIR) to a writable folder"
        )
        raise InputError(msg) from None
    os.environ["MPLCONFIGDIR"] = tmp
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    msg = (
        f"matplotlib's folder {where} cannot be written: its settings and font cache go "
        "to a temporary folder for this run; set MPLCONFIGDIR to a writable folder to "
        "keep them (figures start faster)"
    )
    warnings.warn(msg, KinsyncWarning, stacklevel=2)
