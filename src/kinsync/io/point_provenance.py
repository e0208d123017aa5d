"""The kinsync record of a point file: what made its coordinates, kept in the file.

A surveyor auditing a cloud a year later must be able to tell which mount (boresight,
lever arm, latency and their sigma), which trajectory and which time and CRS options made
it: a LAS header's Generating Software names only kinsync's version. So a point file
kinsync writes holds one JSON document, the *kinsync record* (`point_document`): what
produced it (`kinsync.io.provenance.run_record`: software, command, UTC time), the mount
applied (its values, its TOML text, the file it was read from with that file's SHA-256
and header comments), the input files, the time and CRS options. Where it is kept:

* LAS/LAZ: a VLR of user ID ``kinsync``, record ID `RECORD_ID`, holding the JSON as
  UTF-8. A VLR holds at most 65,535 bytes: a longer record goes into an EVLR in LAS 1.4
  and, in LAS 1.2 and 1.3 (which have none), loses first the mount file's header
  comments, then the command line, then (never met: a CRS of 60 KB) all but the run and
  the mount, each named in its ``left_out``, and a warning says so (`set_las_record`);
* Parquet: the schema's key-value metadata, key `PARQUET_KEY`;
* PLY: header comment lines ``kinsync_record <i>/<n> <piece>`` (`ply_record_comments`):
  the JSON in ASCII, as PLY headers are, cut into pieces of at most `PLY_PIECE_CHARS`
  characters, since readers refuse long header lines (Open3D's RPly aborts on one of
  1,024 characters, CloudCompare's refuses 2,048) and a record with a mount file's
  header comments is kilobytes long;
* CSV: nowhere, since a comment line would break the CSV readers (kinsync's own too).

An input's own kinsync record (a file georeferenced twice) is replaced, never
duplicated. `read_point_record` reads a record back, `record_mount` gives its mount and
`recorded_mount_text` that mount as a mount file.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import laspy
import pyarrow as pa
import pyarrow.parquet as pq
from laspy.vlrs.vlrlist import VLRList

from kinsync.errors import InputError
from kinsync.io.las_header import las_header
from kinsync.io.mount_file import header_comments
from kinsync.io.provenance import command_line_without, run_record
from kinsync.mount import Mount, mount_from_toml_text, mount_to_toml_text

__all__ = [
    "EXECUTION_FLAGS",
    "EXECUTION_OPTIONS",
    "PARQUET_KEY",
    "PLY_PIECE_CHARS",
    "RECORD_DESCRIPTION",
    "RECORD_ID",
    "RECORD_USER_ID",
    "RECORD_VERSION",
    "file_document",
    "mount_document",
    "parquet_record_metadata",
    "ply_record_comments",
    "point_document",
    "read_point_record",
    "record_json",
    "record_mount",
    "recorded_mount_text",
    "set_las_record",
]

RECORD_USER_ID = "kinsync"
"""User ID of the LAS VLR (or EVLR) holding the record."""
RECORD_ID = 1
"""Record ID of that VLR."""
RECORD_DESCRIPTION = "kinsync record: mount, inputs"
"""Its description (at most 32 bytes)."""
PARQUET_KEY = "kinsync"
"""Key of the record in a Parquet file's schema metadata."""
RECORD_VERSION = 1
"""``kinsync_record`` of the documents: the layout of this version."""

PLY_PIECE_CHARS = 900
"""Most characters of the record in one PLY comment line (the line is at most 950 long)."""

_PLY_PREFIX = "kinsync_record "
_PLY_MAX_HEADER_LINES = 100_000  # a 1 MiB mount header, escaped, is ~3,500 pieces
_VLR_MAX_BYTES = 65_535  # the VLR header's record length is a 16-bit count


def file_document(path: Path) -> dict[str, Any]:
    """A file as a record names it: the path as given, its size and SHA-256.

    Parameters
    ----------
    path : Path
        A file this run read (a trajectory, a mount file).

    Returns
    -------
    dict
        ``{"path": str, "bytes": int or None, "sha256": hex str or None}``: None when the
        file cannot be read again (it was read a moment ago).
    """
    path = Path(path)
    try:
        with path.open("rb") as fh:
            digest = hashlib.file_digest(fh, "sha256").hexdigest()
        size: int | None = path.stat().st_size
    except OSError:
        digest, size = None, None
    return {"path": str(path), "bytes": size, "sha256": digest}


def mount_document(mount: Mount, mount_file: Path | None) -> dict[str, Any]:
    """The mount a run applied, for its record.

    Parameters
    ----------
    mount : Mount
        The mount applied (after any option replacing one of its values).
    mount_file : Path or None
        The file it was read from; None for a mount built in Python.

    Returns
    -------
    dict
        ``values`` (`kinsync.mount.Mount.as_document`), ``toml`` (the mount as a mount
        file gives it, `kinsync.mount.mount_to_toml_text`: floats that read back bit
        for bit) and ``file`` (`file_document` with the file's ``header_comments``, or
        None).
    """
    file_doc = None
    if mount_file is not None:
        file_doc = file_document(Path(mount_file)) | {
            "header_comments": header_comments(Path(mount_file))
        }
    return {"values": mount.as_document(), "toml": mount_to_toml_text(mount), "file": file_doc}


def _finite(value: Any) -> Any:
    """``value`` with every float that is not finite (JSON has none) as None."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


EXECUTION_OPTIONS = ("--scheduler", "--workers", "--chunk-points")
"""Options that change how a run works, not the points it writes: left out of the
record's command, so outputs of runs differing only in them are byte-identical."""
EXECUTION_FLAGS = ("--json",)
"""Flags left out of the record's command for the same reason (what is printed)."""


def point_document(
    made_by: str, mount: Mount, mount_file: Path | None, sections: Mapping[str, Any]
) -> dict[str, Any]:
    """The kinsync record of a point file.

    Parameters
    ----------
    made_by : str
        What wrote the file (``"georef"``, ``"sync apply"``).
    mount : Mount
        The mount applied.
    mount_file : Path or None
        The file ``mount`` was read from (`mount_document`).
    sections : mapping of str to JSON-ready values
        What else made the coordinates: input files, time and CRS options.

    Returns
    -------
    dict
        ``kinsync_record`` (`RECORD_VERSION`), ``made_by``, the run
        (`kinsync.io.provenance.run_record`: ``software``, ``command`` without
        `EXECUTION_OPTIONS` and `EXECUTION_FLAGS`, ``utc``),
        ``mount`` (`mount_document`), then ``sections``; a non-finite float is null.
    """
    doc: dict[str, Any] = {"kinsync_record": RECORD_VERSION, "made_by": made_by}
    doc |= run_record()
    # How the work ran is not what made the coordinates: the file stays byte-identical.
    doc["command"] = command_line_without(EXECUTION_OPTIONS, EXECUTION_FLAGS)
    doc["mount"] = mount_document(mount, mount_file)
    return dict(_finite(doc | dict(sections)))


def record_json(doc: Mapping[str, Any], *, ascii_only: bool = False) -> str:
    """The record as one line of JSON (non-ASCII characters escaped on request)."""
    return json.dumps(doc, ensure_ascii=ascii_only, allow_nan=False)


def parquet_record_metadata(doc: Mapping[str, Any]) -> dict[str, str]:
    """The schema metadata that holds the record in a Parquet file: ``{PARQUET_KEY: JSON}``."""
    return {PARQUET_KEY: record_json(doc)}


def _cut(text: str, size: int) -> list[str]:
    """``text`` in pieces of at most ``size`` characters, joined back by concatenation.

    No piece begins or ends with a space where it can be helped: a PLY reader may trim
    a comment line's spaces.
    """
    pieces: list[str] = []
    start = 0
    while len(text) - start > size:
        cut = start + size
        while cut > start + size // 2 and " " in (text[cut - 1], text[cut]):
            cut -= 1
        if " " in (text[cut - 1], text[cut]):  # hundreds of spaces in a row: cut anyway
            cut = start + size
        pieces.append(text[start:cut])
        start = cut
    return [*pieces, text[start:]]


def ply_record_comments(doc: Mapping[str, Any]) -> list[str]:
    """The PLY header comments that hold the record, in order.

    Parameters
    ----------
    doc : mapping
        The record (`point_document`).

    Returns
    -------
    list of str
        ``kinsync_record <i>/<n> <piece>`` for i = 1..n: the record's JSON (ASCII, other
        characters escaped) is the pieces joined, each at most `PLY_PIECE_CHARS` long.
    """
    pieces = _cut(record_json(doc, ascii_only=True), PLY_PIECE_CHARS)
    return [f"{_PLY_PREFIX}{i}/{len(pieces)} {p}" for i, p in enumerate(pieces, 1)]


def _is_record(vlr: Any) -> bool:
    return bool(vlr.user_id == RECORD_USER_ID and vlr.record_id == RECORD_ID)


def _without(records: Any) -> Any:
    """A VLR list without kinsync records (None stays None)."""
    if records is None:
        return None
    return VLRList([v for v in records if not _is_record(v)])


_SHORTENED = (
    ("mount file header comments", ("mount", "file", "header_comments")),
    ("command", ("command",)),
)
"""What a LAS 1.2/1.3 record too long for a VLR loses, in this order; then every section
but `_ESSENTIAL`."""
_ESSENTIAL = ("kinsync_record", "made_by", "software", "utc", "mount", "left_out")


def _shortened(doc: dict[str, Any], label: str, keys: Sequence[str]) -> dict[str, Any]:
    """``doc`` with the value at ``keys`` set to None and ``label`` added to ``left_out``."""
    out: dict[str, Any] = json.loads(json.dumps(doc))
    inner = out
    for key in keys[:-1]:
        inner = inner.get(key) or {}
    if not isinstance(inner, dict) or not inner.get(keys[-1]):  # nothing to leave out
        return out
    inner[keys[-1]] = None
    out["left_out"] = [*out.get("left_out", []), label]
    return out


def set_las_record(header: laspy.LasHeader, doc: Mapping[str, Any], path: Path) -> tuple[str, ...]:
    """Put the record into a LAS header, replacing any kinsync record it has.

    Parameters
    ----------
    header : laspy.LasHeader
        The header of the file to write (changed in place); its other VLRs and EVLRs are
        kept.
    doc : mapping
        The record (`point_document`).
    path : Path
        The file, for the note.

    Returns
    -------
    tuple of str
        Empty when the record went whole into a VLR or (LAS 1.4, over 65,535 bytes) an
        EVLR; else one note naming what a LAS 1.2/1.3 VLR had no room for (the record's
        ``left_out`` names it too): nothing is refused, nothing cut silently.
    """
    header.vlrs = _without(header.vlrs)
    header.evlrs = _without(header.evlrs)
    data = record_json(doc).encode("utf-8")
    if len(data) > _VLR_MAX_BYTES and header.version.minor >= 4:  # LAS 1.4
        evlrs = header.evlrs if header.evlrs is not None else VLRList()
        evlrs.append(laspy.VLR(RECORD_USER_ID, RECORD_ID, RECORD_DESCRIPTION, data))
        header.evlrs = evlrs
        return ()
    record = dict(doc)
    for label, keys in _SHORTENED:
        if len(data) <= _VLR_MAX_BYTES:
            break
        record = _shortened(record, label, keys)
        data = record_json(record).encode("utf-8")
    if len(data) > _VLR_MAX_BYTES:  # a CRS of 60 KB: the mount and the run, the rest named
        kept = {k: v for k, v in record.items() if k in _ESSENTIAL}
        gone = [k for k, v in record.items() if k not in kept and v is not None]
        record = kept | {"left_out": [*record.get("left_out", []), *gone]}
        data = record_json(record).encode("utf-8")
    header.vlrs.append(laspy.VLR(RECORD_USER_ID, RECORD_ID, RECORD_DESCRIPTION, data))
    if "left_out" not in record:
        return ()
    left_out = " and the ".join(record["left_out"])
    note = (
        f"{path}: its kinsync record (a VLR) leaves out the {left_out}: a LAS "
        f"{header.version} VLR holds {_VLR_MAX_BYTES} bytes and the whole record "
        f"{len(record_json(doc).encode('utf-8'))}; a LAS 1.4 output holds it whole"
    )
    return (note,)


def _las_record_bytes(path: Path) -> bytes | None:
    header = las_header(path)
    for records in (header.vlrs, header.evlrs or ()):
        for vlr in records:
            if _is_record(vlr):
                return bytes(vlr.record_data)
    return None


def _parquet_record_bytes(path: Path) -> bytes | None:
    try:
        metadata = pq.read_schema(path).metadata or {}
    except (OSError, pa.ArrowException) as err:
        msg = f"{path}: cannot read it as Parquet ({err})"
        raise InputError(msg) from err
    value = metadata.get(PARQUET_KEY.encode("ascii"))
    return None if value is None else bytes(value)


def _ply_record_lines(path: Path) -> list[bytes]:
    """What follows ``comment kinsync_record `` on the lines of a PLY header, in order."""
    start = f"comment {_PLY_PREFIX}".encode("ascii")
    found: list[bytes] = []
    try:
        with path.open("rb") as fh:
            for _ in range(_PLY_MAX_HEADER_LINES):  # a header; binary points follow end_header
                line = fh.readline(1 << 24).rstrip(b"\r\n")
                if line == b"end_header" or not line:
                    break
                if line.startswith(start):
                    found.append(line[len(start) :])
    except OSError as err:
        msg = f"{path}: cannot read it ({err.strerror or err})"
        raise InputError(msg) from err
    return found


def _ply_record_bytes(path: Path) -> bytes | None:
    lines = _ply_record_lines(path)
    if len(lines) == 1 and lines[0].startswith(b"{"):  # one line: kinsync before pieces
        return lines[0]
    pieces = []
    for i, line in enumerate(lines, 1):
        head, _, piece = line.partition(b" ")
        if head != f"{i}/{len(lines)}".encode("ascii"):
            msg = (
                f"{path}: its kinsync record's header comment {i} of {len(lines)} begins "
                f"{head[:20].decode('ascii', 'replace')!r}, not {i}/{len(lines)}: pieces are "
                "missing or out of order; it is damaged, georeference the points again"
            )
            raise InputError(msg)
        pieces.append(piece)
    return b"".join(pieces) if pieces else None


_TEXT, _OBJECT, _NUMBER, _TEXTS = "a text", "an object", "a number", "a list of texts"
_FIELDS = (
    ("made_by", _TEXT),
    ("software", _TEXT),
    ("utc", _TEXT),
    ("command", _TEXT),
    ("mount", _OBJECT),
    ("mount.toml", _TEXT),
    ("mount.values", _OBJECT),
    ("mount.file", _OBJECT),
    ("mount.file.path", _TEXT),
    ("mount.file.bytes", _NUMBER),
    ("mount.file.sha256", _TEXT),
    ("mount.file.header_comments", _TEXTS),
    ("points", _OBJECT),
    ("points.path", _TEXT),
    ("trajectory", _OBJECT),
    ("trajectory.path", _TEXT),
    ("time", _OBJECT),
    ("clock", _OBJECT),
    ("crs", _OBJECT),
    ("crs.epoch_year", _NUMBER),
    ("left_out", _TEXTS),
)
"""The fields of a record that kinsync reads back, and their JSON types (each may be
null or absent), a field's parents before it."""


def _json_kind(value: Any) -> str:
    kinds = ((bool, "true/false"), (str, _TEXT), (dict, _OBJECT), (list, "a list"))
    return next((k for t, k in kinds if isinstance(value, t)), _NUMBER)


def _check_fields(doc: Mapping[str, Any], path: Path) -> None:
    """Refuse a record whose `_FIELDS` have other JSON types (a record edited by hand)."""
    for field, kind in _FIELDS:
        value: Any = doc
        for key in field.split("."):  # a parent is an object or null: checked before
            value = value.get(key) if isinstance(value, Mapping) else None
        if value is None:
            continue
        ok = _json_kind(value) == kind
        if kind == _TEXTS:
            ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
        if not ok:
            shown = json.dumps(value, ensure_ascii=False, default=str)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            msg = (
                f"{path}: its kinsync record's {field} is {_json_kind(value)} ({shown}), "
                f"not {kind}: the record is damaged (edited by hand?); restore the file or "
                "georeference the points again"
            )
            raise InputError(msg)


def read_point_record(path: Path) -> dict[str, Any]:
    """The kinsync record of a point file kinsync wrote (LAS/LAZ, Parquet, PLY).

    Parameters
    ----------
    path : Path
        A ``.las``, ``.laz``, ``.parquet`` or ``.ply`` file.

    Returns
    -------
    dict
        The record (`point_document`).

    Raises
    ------
    InputError
        A missing or unreadable file, a CSV or other type (which holds no record), a
        file without a kinsync record (not written by ``kinsync georef`` or ``sync
        apply``, or by a version before records), a record that is not JSON, or one
        whose fields kinsync reads (the mount, its file, the CRS epoch, ...) have
        other JSON types, naming the field.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        msg = f"{path}: no such file; give a point file kinsync wrote (.las, .laz, .parquet, .ply)"
        raise InputError(msg)
    if suffix in (".las", ".laz"):
        data, where = _las_record_bytes(path), f"VLR {RECORD_USER_ID!r} {RECORD_ID}"
    elif suffix == ".parquet":
        data, where = _parquet_record_bytes(path), f"schema metadata key {PARQUET_KEY!r}"
    elif suffix == ".ply":
        data, where = _ply_record_bytes(path), "header comments 'kinsync_record <i>/<n> ...'"
    else:
        msg = (
            f"{path}: a {suffix or 'suffix-less'} file holds no kinsync record (a CSV has "
            "nowhere to keep one); give a .las, .laz, .parquet or .ply output of kinsync"
        )
        raise InputError(msg)
    if data is None:
        msg = (
            f"{path}: has no kinsync record ({where}): it was not written by kinsync georef "
            "or sync apply, or by a kinsync older than its records"
        )
        raise InputError(msg)
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as err:
        msg = f"{path}: its kinsync record ({where}) is not UTF-8 JSON ({err}); it is damaged"
        raise InputError(msg) from err
    if not isinstance(doc, dict):
        msg = f"{path}: its kinsync record ({where}) is not a JSON object; it is damaged"
        raise InputError(msg)
    _check_fields(doc, path)
    return doc


def record_mount(doc: Mapping[str, Any], path: Path) -> Mount:
    """The mount a record names, read from its ``mount.toml`` (bit for bit).

    Parameters
    ----------
    doc : mapping
        A record (`read_point_record`).
    path : Path
        The file it came from, for messages.

    Returns
    -------
    Mount

    Raises
    ------
    InputError
        A record without a mount, or one whose mount TOML is not a valid mount.
    """
    mount = doc.get("mount")
    text = mount.get("toml") if isinstance(mount, Mapping) else None
    if not isinstance(text, str):
        msg = f"{path}: its kinsync record holds no mount (mount.toml); it is damaged"
        raise InputError(msg)
    return mount_from_toml_text(text, source=f"{path}: kinsync record mount")


_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")
"""Characters a TOML comment may not hold (tab aside)."""


def _comment_line(text: str) -> str:
    """``text`` as one valid TOML comment line.

    ``# `` is put first where it lacks ``#``; control characters and lone surrogates
    (which a TOML comment or UTF-8 cannot hold) are escaped.
    """
    line = " ".join(text.splitlines())
    line = _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", line)
    line = line.encode("utf-8", "backslashreplace").decode("utf-8")
    return line if line.startswith("#") else f"# {line}"


def recorded_mount_text(doc: Mapping[str, Any], path: Path) -> str:
    """A mount TOML file of the mount a record names, headed by where it comes from.

    Parameters
    ----------
    doc : mapping
        A record (`read_point_record`).
    path : Path
        The point file it came from.

    Returns
    -------
    str
        Comment lines (what writes it now, `kinsync.io.provenance.run_record`; the point
        file and what made it; the mount file it was read from and that file's header
        comments, after a ``# <name>'s header:`` line, as `kinsync.io.mount_file.write_mount`
        heads a derived mount), a blank line, then the record's mount TOML as stored: its
        values read back bit for bit. Every comment is one valid TOML comment line
        (``# `` put before a header comment without ``#``, control characters escaped),
        and the text is checked to read back as the record's mount.

    Raises
    ------
    InputError
        A record without a valid mount (`record_mount`), or one whose mount file would
        not read back as that mount.
    """
    mount = record_mount(doc, path)  # refuses a record without a valid mount
    now = run_record()
    lines = [f"# written by {now['software']} at {now['utc']}"]
    if now["command"] is not None:
        lines.append(f"# command: {now['command']}")
    made = f"{doc.get('made_by')} by {doc.get('software')} at {doc.get('utc')}"
    lines.append(f"# the mount of {path}'s kinsync record: {made}")
    if doc.get("command"):
        lines.append(f"# its command: {doc['command']}")
    file_doc = doc["mount"].get("file")
    if isinstance(file_doc, Mapping):
        lines.append(f"# read from {file_doc.get('path')} (SHA-256 {file_doc.get('sha256')})")
        comments = file_doc.get("header_comments") or []
        if comments:
            name = Path(str(file_doc.get("path"))).name
            lines += [f"# {name}'s header:", *(str(c) for c in comments)]
    head = "\n".join(_comment_line(line) for line in lines)
    text = head + "\n\n" + str(doc["mount"]["toml"]).lstrip("\ufeff")
    try:
        back = mount_from_toml_text(text.encode("utf-8").decode("utf-8"), source=str(path))
        same = mount_to_toml_text(back) == mount_to_toml_text(mount)
    except (InputError, UnicodeEncodeError) as err:
        same, why = False, f" ({err})"
    else:
        why = ""
    if not same:
        msg = (
            f"{path}: the mount file made from its kinsync record does not read back as the "
            f"record's mount{why}: the record's mount.toml is damaged; restore the file or "
            "georeference the points again"
        )
        raise InputError(msg)
    return text
