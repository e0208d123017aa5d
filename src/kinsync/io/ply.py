"""PLY point clouds (binary little-endian), written in chunks.

`PlyChunkWriter` writes one ``vertex`` element whose properties are fixed when the
writer is made: ``x, y, z`` as ``double`` (full float64 precision, any CRS) and any
other numeric attribute in the PLY type that holds it (`ply_property_type`): ``char``,
``uchar``, ``short``, ``ushort``, ``int``, ``uint``, ``float``, ``double``; booleans as
``uchar``; 64-bit integers, which PLY does not have, as ``double`` (exact up to 2**53,
larger magnitudes are refused).

The vertex count goes in the header, which is written before the points: the writer
is given the most points it may write (``max_points``), the count is written in a field
that wide, and when fewer points were written (points rejected on the way) the count is
followed by spaces, which PLY readers skip as whitespace. The file is written under a
temporary name and appears only when complete.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

import numpy as np

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, cannot_write_error, finish_then_publish

__all__ = ["PlyChunkWriter", "ply_property_type", "read_ply_vertices"]

_PLY_TYPES: dict[str, str] = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}
_EXACT_INT_MAX = 2**53


def ply_property_type(dtype: Any) -> str:
    """The PLY type that stores values of ``dtype`` (numpy dtype or anything it takes).

    Raises
    ------
    InputError
        A type that is not a number or a boolean (text, dates, ...).
    """
    dt = np.dtype(dtype)
    if dt.kind == "b":
        return "uchar"
    if dt.kind in "iu" and dt.itemsize == 8:
        return "double"
    key = f"{dt.kind}{dt.itemsize}"
    if key not in _PLY_TYPES:
        msg = f"a {dt} attribute cannot be stored in PLY (numbers and booleans only)"
        raise InputError(msg)
    return _PLY_TYPES[key]


def _numpy_type(ply_type: str) -> np.dtype[Any]:
    code = next(k for k, v in _PLY_TYPES.items() if v == ply_type)
    return np.dtype("<" + code)


class PlyChunkWriter:
    """Write a binary little-endian PLY point cloud chunk by chunk, atomically.

    Use as a context manager; the file appears at ``path`` only when the ``with`` block
    ends without an exception.

    Parameters
    ----------
    path : Path
        Output ``.ply`` file.
    properties : sequence of (str, dtype)
        Vertex properties in order: name and the type of the values that will be
        given (`ply_property_type` chooses the PLY type). ``x, y, z`` must be among them.
    max_points : int
        The most points that will be written (sets the width of the count field).
    comments : sequence of str
        Header comment lines (e.g. the CRS), one line each.

    Raises
    ------
    InputError
        A property name that is empty, holds whitespace or non-ASCII characters, or
        repeats; no ``x, y, z``; a type PLY cannot store; a comment with a line break.
    """

    def __init__(
        self,
        path: Path,
        properties: Sequence[tuple[str, Any]],
        max_points: int,
        comments: Sequence[str] = (),
    ) -> None:
        self.path = Path(path)
        names = [name for name, _ in properties]
        for name in names:
            if not name or not name.isascii() or any(c.isspace() for c in name):
                msg = (
                    f"{self.path}: {name!r} cannot be a PLY property name (ASCII without "
                    "spaces); rename the column"
                )
                raise InputError(msg)
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            msg = f"{self.path}: property name(s) {dupes} repeat; give each column one name"
            raise InputError(msg)
        if not {"x", "y", "z"} <= set(names):
            msg = f"{self.path}: a PLY point cloud needs properties x, y, z, got {names}"
            raise InputError(msg)
        for comment in comments:
            if "\n" in comment or "\r" in comment:
                msg = f"{self.path}: a PLY comment is one line, got {comment!r}"
                raise InputError(msg)
        types = []
        for name, dtype in properties:
            try:
                types.append(ply_property_type(dtype))
            except InputError as err:
                msg = f"{self.path}: property {name!r}: {err}"
                raise InputError(msg) from err
        self._names = names
        self._dtype = np.dtype([(n, _numpy_type(t)) for n, t in zip(names, types, strict=True)])
        self._width = len(str(max(int(max_points), 0)))
        head = ["ply", "format binary_little_endian 1.0"]
        head += [f"comment {c}" for c in comments]
        self._before_count = ("\n".join(head) + "\nelement vertex ").encode("ascii")
        props = "".join(f"property {t} {n}\n" for n, t in zip(names, types, strict=True))
        self._after_count = f"\n{props}end_header\n".encode("ascii")
        self._stack: ExitStack | None = None
        self._fh: BinaryIO | None = None
        self.points_written = 0

    def __enter__(self) -> PlyChunkWriter:
        stack = ExitStack()
        tmp = stack.enter_context(atomic_path(self.path))
        try:
            fh = stack.enter_context(tmp.open("wb"))
            fh.write(self._header(0))
        except BaseException as err:
            stack.__exit__(type(err), err, err.__traceback__)
            if isinstance(err, OSError):
                raise cannot_write_error(self.path, err) from err
            raise
        self._stack, self._fh = stack, fh
        return self

    def _header(self, count: int) -> bytes:
        text = str(count).ljust(self._width).encode("ascii")
        return self._before_count + text + self._after_count

    def write(self, columns: Mapping[str, Any]) -> None:
        """Append points: a mapping of every property name to a 1-D array, one length.

        Raises
        ------
        InputError
            Outside the ``with`` block, missing or extra columns, lengths that differ,
            more points than ``max_points``, a 64-bit integer beyond 2**53 in magnitude.
        """
        if self._fh is None:
            msg = f"{self.path}: PlyChunkWriter.write called outside its 'with' block"
            raise InputError(msg)
        if set(columns) != set(self._names):
            msg = f"{self.path}: chunk columns {sorted(columns)} differ from {self._names}"
            raise InputError(msg)
        arrays = [np.asarray(columns[name]) for name in self._names]
        n = {a.shape for a in arrays}
        if len(n) != 1 or len(next(iter(n))) != 1:
            msg = f"{self.path}: columns must be 1-D of one length, got shapes {sorted(n)}"
            raise InputError(msg)
        count = arrays[0].shape[0]
        if self.points_written + count > 10**self._width - 1:
            msg = (
                f"{self.path}: {self.points_written + count} points, more than the "
                f"{10**self._width - 1} the header was written for"
            )
            raise InputError(msg)
        out = np.empty(count, dtype=self._dtype)
        for name, values in zip(self._names, arrays, strict=True):
            if values.dtype.kind in "iu" and values.dtype.itemsize == 8:
                big = np.flatnonzero((values > _EXACT_INT_MAX) | (values < -_EXACT_INT_MAX))
                if big.size:
                    row = self.points_written + int(big[0]) + 1  # counted from 1
                    msg = (
                        f"{self.path}: point {row} of the output, {name} = "
                        f"{int(values[big[0]])}: PLY has no 64-bit integers and a double "
                        "holds integers exactly only up to 2**53; store this attribute "
                        "another way"
                    )
                    raise InputError(msg)
            out[name] = values
        try:
            self._fh.write(out.tobytes())
        except OSError as err:
            raise cannot_write_error(self.path, err) from err
        self.points_written += count

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        stack, self._stack = self._stack, None
        fh, self._fh = self._fh, None
        if stack is None or fh is None:
            return

        def finish() -> None:
            if exc_type is None:
                fh.seek(0)
                fh.write(self._header(self.points_written))

        finish_then_publish(stack, finish, exc_type, exc, tb)


def read_ply_vertices(path: Path) -> dict[str, np.ndarray[Any, Any]]:
    """Read the ``vertex`` element of a binary little-endian PLY file (as written here).

    Returns
    -------
    dict of str to ndarray, shape (N,)
        Every vertex property in file order, in its PLY type.

    Raises
    ------
    InputError
        Not a PLY file, another format than binary little-endian, list properties or
        elements before ``vertex``, or fewer bytes than the header announces.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as err:
        msg = f"{path}: cannot read ({err.strerror or err})"
        raise InputError(msg) from err
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        msg = f"{path}: not a PLY file (no 'ply' line or no 'end_header')"
        raise InputError(msg)
    lines = data[:end].decode("ascii", errors="replace").splitlines()
    if "format binary_little_endian 1.0" not in lines:
        msg = f"{path}: only binary little-endian PLY is read here"
        raise InputError(msg)
    count = -1
    fields: list[tuple[str, np.dtype[Any]]] = []
    for line in lines:
        words = line.split()
        if words[:2] == ["element", "vertex"] and len(words) == 3 and words[2].isdigit():
            count = int(words[2])
        elif words[:1] == ["element"]:
            msg = f"{path}: element {words[1:]!r} besides vertex is not read here"
            raise InputError(msg)
        elif words[:1] == ["property"]:
            if len(words) != 3 or words[1] not in _PLY_TYPES.values():
                msg = f"{path}: property line {line!r} is not a scalar PLY property"
                raise InputError(msg)
            fields.append((words[2], _numpy_type(words[1])))
    if count < 0:
        msg = f"{path}: no 'element vertex N' line"
        raise InputError(msg)
    dtype = np.dtype(fields)
    body = data[end + len(b"end_header\n") :]
    if len(body) < count * dtype.itemsize:
        msg = (
            f"{path}: {count} vertices of {dtype.itemsize} bytes announced, "
            f"{len(body)} bytes present"
        )
        raise InputError(msg)
    array = np.frombuffer(body, dtype=dtype, count=count)
    return {name: array[name].copy() for name, _ in fields}
