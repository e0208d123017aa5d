"""Binary files of fixed-size little-endian records (SBET, smrmsg), memory-mapped."""

from __future__ import annotations

import stat
from pathlib import Path
from typing import Any

import numpy as np

from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path
from kinsync.io.sanity import check_record_file, link_loop_error, not_a_regular_file

__all__ = ["MAX_RECORD_FILE_BYTES", "count_records", "memmap_records", "write_records"]

MAX_RECORD_FILE_BYTES = 8 << 30
"""Largest record file read (8 GiB: 2 days of a 200 Hz SBET). Its records are copied into
arrays of about the file's size (twice for a trajectory)."""


def count_records(path: Path, dtype: np.dtype[Any], kind: str, mismatch_hint: str) -> int:
    """Number of fixed-size records in a file, checking its length (`memmap_records`).

    Raises
    ------
    InputError
        As `memmap_records`, except for the mapping itself.
    """
    path = Path(path)
    size_b = dtype.itemsize
    try:
        st = path.stat()
    except FileNotFoundError as err:
        msg = f"{path}: file not found; give the path of an {kind} file"
        raise InputError(msg) from err
    except OSError as err:
        loop = link_loop_error(path, err, f"{kind} file")
        if loop is not None:
            raise loop from err
        msg = f"{path}: cannot read ({err})"
        raise InputError(msg) from err
    if stat.S_ISDIR(st.st_mode):
        msg = f"{path}: is a folder; give the path of an {kind} file"
        raise InputError(msg)
    if not stat.S_ISREG(st.st_mode):  # a pipe or a device: its size says nothing
        raise not_a_regular_file(path, f"{kind} file")
    size = st.st_size
    n, left = divmod(size, size_b)
    if left:
        msg = (
            f"{path}: length {size} bytes is not a multiple of the {size_b}-byte "
            f"{kind} record: {n} whole records and {left} bytes left over; {mismatch_hint}"
        )
        raise InputError(msg)
    if n == 0:
        msg = f"{path}: empty file; an {kind} file holds {size_b}-byte records"
        raise InputError(msg)
    check_record_file(path, size_b, kind, MAX_RECORD_FILE_BYTES)
    return n


def memmap_records(
    path: Path, dtype: np.dtype[Any], kind: str, mismatch_hint: str
) -> np.memmap[tuple[int], np.dtype[np.void]]:
    """Memory-map a file of fixed-size records (read-only), checking its length.

    Parameters
    ----------
    path : Path
        The file.
    dtype : numpy.dtype
        One record (its ``itemsize`` is the record length in bytes).
    kind : str
        What the file is, for messages ("SBET", "smrmsg").
    mismatch_hint : str
        What to tell the user when the length is not a whole number of records.

    Raises
    ------
    InputError
        Missing, unreadable or empty file, a folder, a length that is not a multiple of the
        record size, a file larger than `MAX_RECORD_FILE_BYTES`, or one whose first
        64 KiB of records are all zero bytes (`kinsync.io.sanity.check_record_file`).
    """
    path = Path(path)
    n = count_records(path, dtype, kind, mismatch_hint)
    try:
        return np.memmap(path, dtype=dtype, mode="r", shape=(n,))
    except OSError as err:
        msg = f"{path}: cannot memory-map ({err})"
        raise InputError(msg) from err


def write_records(records: np.ndarray[Any, Any], path: Path) -> None:
    """Write a structured array of records to ``path``, atomically (`atomic_path`).

    Written through a Python file, not ``ndarray.tofile``: numpy reports a short write
    ("N requested and M written") without its error number, and a full disk would not be
    recognised as one.

    Parameters
    ----------
    records : ndarray, shape (N,)
        The records, in their file layout (a little-endian structured dtype).
    path : Path
        The file to write.
    """
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        fh.write(np.ascontiguousarray(records).view(np.uint8).data)
