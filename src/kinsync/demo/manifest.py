"""The demo's list of what it wrote, so that a re-run replaces only the demo's own files.

`MANIFEST` holds one line per file the demo wrote, ``SHA256  relative/path`` (the
layout of ``sha256sum``). A re-run into the same folder replaces the folder as a whole,
so it first refuses one that holds anything else: a file not listed, a listed file whose
content changed since the demo wrote it (a user's figure saved under a demo name), a
symbolic link, a folder that holds none of the listed files. A demo folder without the
list (written by an older kinsync, or the list removed) cannot be told from the user's
files and is refused too.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from kinsync._text import first_few
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text

__all__ = ["MANIFEST", "check_manifest", "write_manifest"]

MANIFEST = "demo-files.txt"
"""Every file the demo wrote, with its SHA-256 (one ``HASH  path`` line each)."""

_CHUNK = 1 << 20


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        while block := fh.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def _entries(folder: Path) -> tuple[list[str], list[str], list[str]]:
    """Regular files, symbolic links and folders under ``folder`` (relative ``/`` paths)."""
    files: list[str] = []
    links: list[str] = []
    dirs: list[str] = []
    for root, dirnames, filenames in os.walk(folder):  # links are not followed
        base = Path(root)
        for name in dirnames + filenames:
            path = base / name
            rel = path.relative_to(folder).as_posix()
            if path.is_symlink():
                links.append(rel)
            elif name in dirnames:
                dirs.append(rel)
            else:
                files.append(rel)
    return sorted(files), sorted(links), sorted(dirs)


def write_manifest(folder: Path) -> None:
    """List every file under ``folder`` with its SHA-256 in ``folder/MANIFEST``."""
    folder = Path(folder)
    files, _, _ = _entries(folder)
    lines = [f"{_sha256(folder / rel)}  {rel}\n" for rel in files if rel != MANIFEST]
    atomic_write_text(folder / MANIFEST, "".join(lines))


def _read_manifest(folder: Path) -> dict[str, str]:
    manifest = folder / MANIFEST
    try:
        text = manifest.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        msg = f"--out {folder}: cannot read {MANIFEST} ({err}); choose another --out"
        raise InputError(msg) from err
    listed: dict[str, str] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        digest, sep, rel = line.partition("  ")
        if not sep or len(digest) != 64 or not rel:
            msg = (
                f"--out {folder}: {MANIFEST} line {number} is not 'SHA256  path' (written by "
                "an older kinsync, or edited): move the folder away or choose another --out"
            )
            raise InputError(msg)
        listed[rel] = digest
    return listed


def check_manifest(folder: Path) -> None:
    """Refuse an earlier demo folder that holds anything the demo did not write.

    Parameters
    ----------
    folder : Path
        An existing folder holding an earlier demo report.

    Raises
    ------
    InputError
        No `MANIFEST`, or a file, link or folder it does not list, or a listed file
        whose content changed; the message names them.
    """
    folder = Path(folder)
    if not (folder / MANIFEST).is_file():
        msg = (
            f"--out {folder}: an earlier demo report without {MANIFEST} (from an older "
            "kinsync, or the list was removed), so its files cannot be told from yours: "
            "move the folder away or choose another --out"
        )
        raise InputError(msg)
    listed = _read_manifest(folder)
    files, links, dirs = _entries(folder)
    holders = {parent.as_posix() for rel in listed for parent in Path(rel).parents}
    others = [rel for rel in files if rel not in listed and rel != MANIFEST]
    others += links
    others += [rel for rel in dirs if rel not in holders]
    changed = [rel for rel in files if rel in listed and _sha256(folder / rel) != listed[rel]]
    if not (others or changed):
        return
    parts = []
    if others:
        parts.append(f"entries the demo did not write ({first_few(sorted(others))})")
    if changed:
        parts.append(f"files changed since the demo wrote them ({first_few(sorted(changed))})")
    msg = (
        f"--out {folder}: an earlier demo report, but it holds {' and '.join(parts)}; a re-run "
        "replaces the whole folder: move them, or choose another --out"
    )
    raise InputError(msg)
