"""LAS point records and table columns, each made from the other.

LAS -> table (`las_column_types`, `las_columns`): one column per dimension of the
point format, in its order, named as laspy names them (``intensity``,
``return_number``, ``classification``, ``gps_time``, extra bytes by their own names);
``X, Y, Z`` are new float64 coordinates; bit fields become uint8; an extra dimension
with a scale or an offset becomes float64 (its real values, stored x scale + offset),
others keep their stored type; an extra dimension of several values (``3f8``) becomes
one column per value (``name_0``, ``name_1``, ...).

Table -> LAS (`plan_table_las`, `TableLasPlan`): LAS 1.4, point format 6 (7 with
``red, green, blue``, 8 with ``nir`` too). The time of each point (``t_s``) goes to
``gps_time``: as adjusted standard GPS time (GPS time - 1e9 s, the global-encoding bit
set) when the times are GPS time, as they are when they are GPS seconds of week. A
column named as a standard dimension of the point format (``intensity``,
``return_number``, ``classification``, ``user_data``, ``scan_angle``,
``point_source_id``, the flags, ``red``...) fills it: its values must be whole numbers
within the dimension's range. A column named ``X``, ``Y`` or ``Z`` (any case) is refused:
LAS stores the new coordinates there. Without ``return_number`` / ``number_of_returns`` columns
a point is return 1 of 1 (LAS numbers returns from 1). Every other numeric or boolean
column is stored as an extra-bytes dimension of its own type (float64, int64, ...;
booleans uint8), so that nothing numeric is lost; text columns cannot be stored in LAS
and are named in ``dropped``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal

import laspy
import numpy as np
import pyarrow as pa

from kinsync.errors import InputError
from kinsync.io.las import ADJUSTED_GPS_OFFSET_S
from kinsync.io.las_header import set_global_encoding_bit

__all__ = [
    "TableLasPlan",
    "arrow_numpy_dtype",
    "las_column_types",
    "las_columns",
    "plan_table_las",
]

_XYZ = ("X", "Y", "Z")
_COORDINATES = ("x", "y", "z")  # X, Y, Z in any case: laspy's x, y, z are the same values
_COLOUR = ("red", "green", "blue")
_EXTRA_NAME_BYTES = 32  # LAS 1.4 extra bytes descriptor: name field of 32 bytes


def _dimension_columns(pf: laspy.PointFormat) -> list[tuple[str, str, np.dtype[Any], int]]:
    """``(column, dimension, dtype, index)`` of every non-coordinate dimension.

    ``index`` is -1 for a scalar dimension, else the position in a multi-value one.
    An extra dimension with a scale or an offset has float64 columns: laspy gives its
    real values (stored x scale + offset), which its stored type cannot hold.
    """
    out: list[tuple[str, str, np.dtype[Any], int]] = []
    for dim in pf.dimensions:
        if dim.name in _XYZ:
            continue
        if dim.kind == laspy.DimensionKind.BitField:
            out.append((dim.name, dim.name, np.dtype(np.uint8), -1))
            continue
        dt = np.dtype(dim.dtype)
        scaled = not dim.is_standard and dim.is_scaled
        if dt.subdtype is not None:
            base, shape = dt.subdtype
            if scaled:
                base = np.dtype(np.float64)
            count = int(np.prod(shape))
            out.extend((f"{dim.name}_{i}", dim.name, base, i) for i in range(count))
        else:
            out.append((dim.name, dim.name, np.dtype(np.float64) if scaled else dt, -1))
    return out


def las_column_types(pf: laspy.PointFormat) -> dict[str, np.dtype[Any]]:
    """Column names and types of `las_columns` for point format ``pf``, in order."""
    others = _dimension_columns(pf)
    result: dict[str, np.dtype[Any]] = {}
    for dim in pf.dimensions:
        if dim.name in _XYZ:
            result[dim.name] = np.dtype(np.float64)
        result |= {column: dt for column, name, dt, _ in others if name == dim.name}
    return result


def las_columns(
    array: np.ndarray[Any, Any], pf: laspy.PointFormat, xyz: np.ndarray[Any, Any]
) -> dict[str, np.ndarray[Any, Any]]:
    """Table columns of LAS point records: every dimension, ``X, Y, Z`` from ``xyz``.

    Parameters
    ----------
    array : structured ndarray, shape (N,)
        Point records of point format ``pf`` (``ScaleAwarePointRecord.array``).
    pf : laspy.PointFormat
        Their point format (extra dimensions included).
    xyz : ndarray, shape (N, 3)
        The coordinates to give as ``X, Y, Z`` (e.g. georeferenced), float64.

    Returns
    -------
    dict of str to ndarray, shape (N,)
        In the order of `las_column_types`.
    """
    record = laspy.PackedPointRecord(array, pf)
    dims = {c: (d, i) for c, d, _, i in _dimension_columns(pf)}
    out: dict[str, np.ndarray[Any, Any]] = {}
    for column, dt in las_column_types(pf).items():
        if column in _XYZ:
            out[column] = np.ascontiguousarray(xyz[:, _XYZ.index(column)])
            continue
        dim, index = dims[column]
        values = np.asarray(record[dim])
        out[column] = (values if index < 0 else values[:, index]).astype(dt, copy=False)
    return out


def _integer_range(pf: laspy.PointFormat, name: str) -> tuple[int, int]:
    dim = pf.dimension_by_name(name)
    bits = int(dim.num_bits)
    if dim.kind == laspy.DimensionKind.SignedInteger:
        return -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    return 0, 2**bits - 1


def _default_returns(record: laspy.PackedPointRecord, given: Sequence[str]) -> None:
    """Fill the return fields a table does not give: 1 of 1 (LAS returns are 1 to 15).

    A missing ``return_number`` is 1; a missing ``number_of_returns`` is the return
    number (at least 1), so that a table without return columns gives single returns.
    """
    if "return_number" not in given:
        record["return_number"] = np.ones(len(record), dtype=np.uint8)
    if "number_of_returns" not in given:
        record["number_of_returns"] = np.maximum(np.asarray(record["return_number"]), 1)


@dataclass(frozen=True)
class TableLasPlan:
    """How the columns of a point table become LAS points (see the module docstring).

    Attributes
    ----------
    point_format_id : int
        6, 7 or 8.
    standard : tuple of str
        Columns stored in the standard dimension of the same name.
    extra : tuple of (str, str)
        Columns stored as extra-bytes dimensions: name and numpy type (``"f8"``, ...).
    dropped : tuple of str
        Text columns, which LAS cannot store.
    time_scale : {"gps", "week"}
        Times are GPS time (stored as adjusted standard GPS time) or GPS seconds of week.
    """

    point_format_id: int
    standard: tuple[str, ...]
    extra: tuple[tuple[str, str], ...]
    dropped: tuple[str, ...]
    time_scale: Literal["gps", "week"]

    def header(self) -> laspy.LasHeader:
        """A LAS 1.4 header for the points (scales and offsets set by the writer)."""
        header = laspy.LasHeader(point_format=self.point_format_id, version="1.4")
        if self.extra:
            header.add_extra_dims([laspy.ExtraBytesParams(n, t) for n, t in self.extra])
        set_global_encoding_bit(
            header, laspy.header.GlobalEncoding.GPS_TIME_TYPE_MASK, on=self.time_scale == "gps"
        )
        return header

    @cached_property
    def _point_format(self) -> laspy.PointFormat:
        return self.header().point_format

    def records(
        self, t_s: np.ndarray[Any, Any], columns: Mapping[str, np.ndarray[Any, Any]]
    ) -> tuple[np.ndarray[Any, Any], tuple[int, str] | None]:
        """Point records for rows of the table; X, Y, Z left 0 for the caller to store.

        Parameters
        ----------
        t_s : ndarray, shape (N,)
            Times of the points (s), on the scale of ``time_scale``.
        columns : mapping of str to ndarray, shape (N,)
            The table's columns (at least those of ``standard`` and ``extra``).

        Returns
        -------
        records : structured ndarray, shape (N,)
            Of the plan's point format, extra dimensions included.
        error : (int, str) or None
            The first value that does not fit its dimension: its row within these N and
            what is wrong (``"column 'intensity': 70000 does not fit ..."``), or None.
        """
        pf = self._point_format
        array = np.zeros(len(t_s), dtype=pf.dtype())
        record = laspy.PackedPointRecord(array, pf)
        offset = ADJUSTED_GPS_OFFSET_S if self.time_scale == "gps" else 0.0
        array["gps_time"] = np.asarray(t_s, dtype=np.float64) - offset
        for name in self.standard:
            values = np.asarray(columns[name])
            lo, hi = _integer_range(pf, name)
            as_float = values.astype(np.float64)
            bad = ~((as_float >= lo) & (as_float <= hi) & (np.floor(as_float) == as_float))
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                what = "0 or 1" if (lo, hi) == (0, 1) else f"a whole number {lo}..{hi}"
                error = (
                    f"column {name!r}: {values[row].item()!r} does not fit the LAS {name} "
                    f"dimension ({what}); fix the value, or rename the column so that it is "
                    "stored as an extra dimension of its own"
                )
                return array, (row, error)
            record[name] = as_float.astype(np.int64)
        _default_returns(record, self.standard)
        for name, _ in self.extra:
            array[name] = np.asarray(columns[name])
        return array, None


def plan_table_las(
    column_types: Mapping[str, Any],
    time_scale: Literal["gps", "week"],
    *,
    skip: Sequence[str] = (),
) -> TableLasPlan:
    """Decide how the columns of a table become LAS points.

    Parameters
    ----------
    column_types : mapping of str to dtype
        The table's columns in order with their numpy (or pyarrow) types; the time
        and coordinate columns excluded, or named in ``skip``.
    time_scale : {"gps", "week"}
        Scale of the point times.
    skip : sequence of str
        Columns not to store (the time and the scanner coordinates).

    Raises
    ------
    InputError
        ``red, green, blue`` not all present, a ``nir`` without them, a column that
        would take the ``gps_time`` kinsync fills from the point times, a column named
        ``X``, ``Y`` or ``Z`` in any case (the output coordinates), a column name
        that cannot be an extra dimension (more than 32 bytes, not ASCII, or a name
        LAS keeps for itself).
    """
    names = [n for n in column_types if n not in skip]
    colour = [c for c in _COLOUR if c in names]
    if colour and len(colour) < len(_COLOUR):
        msg = (
            f"columns {colour} of red, green, blue: LAS stores colour as all three; give "
            "the other columns, or rename these so that they are stored as extra dimensions"
        )
        raise InputError(msg)
    pf_id = 6
    if colour:
        pf_id = 8 if "nir" in names else 7
    elif "nir" in names:
        msg = "column 'nir': LAS stores nir with red, green and blue (point format 8)"
        raise InputError(msg)
    pf = laspy.PointFormat(pf_id)
    reserved = {d.lower() for d in pf.dimension_names}
    standard: list[str] = []
    extra: list[tuple[str, str]] = []
    dropped: list[str] = []
    for name in names:
        dt = _numpy_type(column_types[name])
        if name == "gps_time":
            msg = (
                "column 'gps_time': kinsync writes the LAS gps_time from the point times "
                "(t_s); map t_s to it (--columns t_s=gps_time) or rename it"
            )
            raise InputError(msg)
        if name.lower() in _COORDINATES:
            msg = (
                f"column {name!r} would clash with the output coordinates X, Y, Z (LAS "
                "stores the georeferenced coordinates there, whatever the case of the "
                "name); rename or remove that column in the file"
            )
            raise InputError(msg)
        if name in pf.dimension_names:
            if dt is None or dt.kind not in "biuf":
                msg = f"column {name!r}: LAS {name} needs numbers, the column holds {dt or 'text'}"
                raise InputError(msg)
            standard.append(name)
            continue
        if dt is None:
            dropped.append(name)
            continue
        if (
            name.lower() in reserved
            or not name.isascii()
            or len(name.encode("ascii")) > _EXTRA_NAME_BYTES
        ):
            msg = (
                f"column {name!r} cannot be a LAS extra dimension (an ASCII name of at most "
                f"{_EXTRA_NAME_BYTES} characters that LAS does not use itself); rename it"
            )
            raise InputError(msg)
        code = "u1" if dt.kind == "b" else dt.str.lstrip("<>|=")
        extra.append((name, code))
    return TableLasPlan(pf_id, tuple(standard), tuple(extra), tuple(dropped), time_scale)


def arrow_numpy_dtype(kind: pa.DataType) -> np.dtype[Any]:
    """The numpy type of a pyarrow column type (``object`` for text and the like).

    Read from an empty array of the type: pyarrow 14's ``DataType.to_pandas_dtype``
    imports pandas, which kinsync does not depend on.

    Raises
    ------
    NotImplementedError, pyarrow.ArrowException
        A type pyarrow cannot convert to numpy.
    """
    empty: np.ndarray[Any, np.dtype[Any]] = pa.array([], type=kind).to_numpy(zero_copy_only=False)
    return empty.dtype


def _numpy_type(kind: Any) -> np.dtype[Any] | None:
    """The numpy type of a column type (numpy or pyarrow); None for text and the like.

    A column of no known type (pyarrow's ``null``: a CSV with a header and no rows)
    is taken as float64: it has no values to lose.
    """
    if str(kind) == "null":
        return np.dtype(np.float64)
    try:
        dt = arrow_numpy_dtype(kind) if isinstance(kind, pa.DataType) else np.dtype(kind)
    except (TypeError, NotImplementedError, pa.ArrowException):
        return None
    return dt if dt.kind in "biuf" else None
