"""The min and max of each Extra Bytes descriptor, from every point written.

A LAS 1.4 Extra Bytes descriptor (ASPRS LAS 1.4 R15, VLR 4, 192 bytes) may declare the
minimum and maximum of its dimension (options bits 1 and 2, fields at bytes 64 and 88,
as stored: before scale and offset, upcast to int64, uint64 or double). laspy 2.7 sets
both bits for every dimension it creates and updates the fields per chunk from the
chunk's first point only, so that a file claimed min = max = the first point's value.
`ExtraBytesRange` follows the stored values of every chunk written and sets the fields
before the header is written the last time; a dimension without a value to bound (no
points, or only no-data values and NaN) has bits 1 and 2 cleared and the fields zeroed.
Descriptors that do not claim a min or max, or whose data type is 0 (raw bytes), are
left as they are.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import laspy
import numpy as np

__all__ = ["ExtraBytesRange"]

_MIN_BIT = 0b0000_0010  # options bit 1: the min field is valid
_MAX_BIT = 0b0000_0100  # options bit 2: the max field is valid


def _descriptors(header: laspy.LasHeader) -> list[Any]:
    """The Extra Bytes descriptors of ``header`` (laspy ``ExtraBytesStruct``), maybe none."""
    found = header.vlrs.get("ExtraBytesVlr")
    return list(found[0].extra_bytes_structs) if found else []


@dataclass
class _Bounds:
    """The stored range seen so far of one element of one extra dimension."""

    name: str
    index: int  # -1 for a dimension of one value, else the position in a multi-value one
    no_data: Any  # the no-data value as stored, or None
    lo: Any = None
    hi: Any = None
    seen: bool = field(default=False)


class ExtraBytesRange:
    """Stored min and max of each Extra Bytes dimension over the chunks written.

    Parameters
    ----------
    header : laspy.LasHeader
        The output's header (its point format and Extra Bytes VLR); not changed.
    """

    def __init__(self, header: laspy.LasHeader) -> None:
        self._bounds: list[_Bounds] = []
        for desc in _descriptors(header):
            if desc.data_type == 0 or not desc.options & (_MIN_BIT | _MAX_BIT):
                continue
            count = int(desc.num_elements())
            no_data = desc.no_data
            for i in range(count):
                nd = None if no_data is None else no_data[i]
                self._bounds.append(_Bounds(desc.format_name(), -1 if count == 1 else i, nd))

    def grow(self, array: np.ndarray[Any, Any]) -> None:
        """Take in the stored values of a chunk.

        Parameters
        ----------
        array : structured ndarray, shape (M,)
            The chunk's point records, extra dimensions as stored (before scale and
            offset).
        """
        for b in self._bounds:
            values = np.asarray(array[b.name])
            if b.index >= 0:
                values = values[:, b.index]
            keep = np.ones(values.shape, dtype=bool)
            if b.no_data is not None:
                keep &= values != b.no_data
            if values.dtype.kind == "f":
                keep &= ~np.isnan(values)
            if not keep.any():
                continue
            lo, hi = values[keep].min().item(), values[keep].max().item()
            b.lo = lo if not b.seen else min(b.lo, lo)
            b.hi = hi if not b.seen else max(b.hi, hi)
            b.seen = True

    def store(self, header: laspy.LasHeader) -> None:
        """Set the min and max fields of ``header``'s descriptors to the values taken in.

        A descriptor with an element that had no value to bound (no points, only no-data
        or NaN) gets its options bits 1 and 2 cleared and both fields zeroed.

        Parameters
        ----------
        header : laspy.LasHeader
            The header about to be written (the one the laspy writer holds), changed in
            place; of the point format and descriptors given to the constructor.
        """
        for desc in _descriptors(header):
            mine = [b for b in self._bounds if b.name == desc.format_name()]
            if not mine:
                continue
            kind = _stored_kind(int(desc.data_type))
            fields = {
                _MIN_BIT: np.frombuffer(desc._min, dtype=kind),
                _MAX_BIT: np.frombuffer(desc._max, dtype=kind),
            }
            known = all(b.seen for b in mine)
            if not known:
                desc.options &= ~(_MIN_BIT | _MAX_BIT)
            for bit, values in fields.items():
                values[:] = 0
                if desc.options & bit:
                    values[: len(mine)] = [b.lo if bit == _MIN_BIT else b.hi for b in mine]


def _stored_kind(data_type: int) -> np.dtype[Any]:
    """The type of the no-data, min and max fields of an Extra Bytes data type (1..30).

    LAS 1.4 R15: unsigned types upcast to uint64, signed to int64, float and double to
    double; the data types 11..30 are the same 10 types in 2 and 3 values.
    """
    base = (data_type - 1) % 10 + 1
    if base in (9, 10):
        return np.dtype(np.float64)
    return np.dtype(np.int64 if base % 2 == 0 else np.uint64)
