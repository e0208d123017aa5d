"""Mount TOML files (schema in `kinsync.mount`), and the reading of kinsync's TOML files."""

from __future__ import annotations

from pathlib import Path

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.io.provenance import run_record
from kinsync.io.sanity import check_not_link_loop, not_a_regular_file
from kinsync.mount import Mount, mount_from_toml_text, mount_to_toml_text

__all__ = ["MAX_TOML_BYTES", "header_comments", "read_mount", "read_toml_text", "write_mount"]

MAX_TOML_BYTES = 1 << 20
"""Largest TOML file read (bytes): kinsync's TOML files hold a few dozen values."""


def read_toml_text(path: Path, what: str) -> str:
    """The text of a small UTF-8 TOML file, for `kinsync.mount.toml_document`.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What the file is, for messages ("mount file", "INS configuration").

    Returns
    -------
    str
        The text as stored (a UTF-8 byte-order mark is kept; the parser drops it), its
        line ends LF: a lone CR (old Mac files, some editors), which the CSV readers take
        as a line end and the TOML parser refuses, becomes one, as does a CRLF.

    Raises
    ------
    InputError
        A missing file, a directory, a device or a pipe, a symbolic link loop, one
        larger than `MAX_TOML_BYTES`, or one that is not UTF-8 text (naming the byte at
        fault), or any other read failure.
    """
    path = Path(path)
    check_not_link_loop(path, what)
    if path.exists() and not path.is_file() and not path.is_dir():
        raise not_a_regular_file(path, what)  # opening a pipe would wait for a writer
    try:
        with path.open("rb") as fh:  # a bounded read: a device or a huge file cannot hang it
            data = fh.read(MAX_TOML_BYTES + 1)
    except FileNotFoundError as err:
        msg = f"{path}: {what} not found"
        raise InputError(msg) from err
    except OSError as err:
        msg = f"{path}: cannot read {what} ({err.strerror or err})"
        raise InputError(msg) from err
    if len(data) > MAX_TOML_BYTES:
        msg = (
            f"{path}: larger than {MAX_TOML_BYTES} bytes, too large for a {what}; is this "
            "the right file?"
        )
        raise InputError(msg)
    try:
        return data.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
    except UnicodeDecodeError as err:
        msg = (
            f"{path}: the {what} is not UTF-8 text (byte {err.start}: {err.reason}); "
            "save it as UTF-8"
        )
        raise InputError(msg) from err


def read_mount(path: Path) -> Mount:
    """Read a mount TOML file; errors name the file (and the line, key or bound at fault)."""
    path = Path(path)
    return mount_from_toml_text(read_toml_text(path, "mount file"), source=str(path))


def write_mount(mount: Mount, path: Path, *, derived_from: Path | None = None) -> None:
    """Write a mount TOML file atomically.

    Parameters
    ----------
    mount : Mount
        The values.
    path : Path
        The file.
    derived_from : Path, optional
        The mount file these values were measured from (a calibration's start): the
        file then begins with what produced it (`kinsync.io.provenance.run_record`: the
        software and its commit, the command, the UTC time) and that file's own header
        comments (a vehicle, a serial number), which its values no longer carry.
    """
    text = mount_to_toml_text(mount)
    if derived_from is not None:
        text = "\n".join(_provenance_comments(Path(derived_from))) + "\n\n" + text
    atomic_write_text(Path(path), text)


def header_comments(path: Path) -> list[str]:
    """The comment lines (``#``) a TOML file begins with, blank lines between them skipped.

    Parameters
    ----------
    path : Path
        A TOML file; one that cannot be read gives none.

    Returns
    -------
    list of str
        The lines as written, ``#`` included.
    """
    try:
        text = read_toml_text(Path(path), "mount file")
    except InputError:
        return []
    out: list[str] = []
    for line in text.lstrip("\ufeff").splitlines():
        stripped = line.strip()
        if stripped.startswith("#"):
            out.append(stripped)
        elif stripped:
            break
    return out


def _provenance_comments(source: Path) -> list[str]:
    """What produced a mount file measured from ``source``, and ``source``'s header."""
    record = run_record()
    lines = [
        f"# written by {record['software']} at {record['utc']}",
        f"# from {source}",
    ]
    if record["command"] is not None:
        lines += [f"# command: {record['command']}", f"# in {Path.cwd()}"]
    kept = header_comments(source)
    if kept and kept[0].startswith(_WRITTEN_BY):  # written by kinsync: its own header only
        mark = next((i for i, c in enumerate(kept) if c.endswith(_HEADER_MARK)), len(kept))
        kept = kept[mark + 1 :]
    if kept:
        lines += [f"# {source.name}{_HEADER_MARK}", *kept]
    return [line.replace("\n", " ").replace("\r", " ") for line in lines]


_WRITTEN_BY = "# written by kinsync "
_HEADER_MARK = "'s header:"
