"""The columns of a point table slice as numbers, for outputs that hold only numbers.

A CSV slice gives the columns that are not required as text (`kinsync.io.points`);
LAS and PLY outputs need them as numbers: `numeric_columns` converts them to the types
pyarrow infers from the file's first MiB (``TableLayout.inferred``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from kinsync._typing import BoolArray
from kinsync.errors import InputError
from kinsync.io.points import TableLayout

__all__ = ["numeric_columns"]


def _cast_error(
    layout: TableLayout,
    name: str,
    values: np.ndarray[Any, Any],
    target: Any,
    where: Callable[[int], str],
) -> InputError:
    """The first value of a text column that does not convert to ``target``."""
    column = layout.file_name(name)
    for i, value in enumerate(values.tolist()):
        try:
            pa.scalar(value, pa.string()).cast(target)
        except (pa.ArrowException, ValueError):
            what = "empty cell" if value == "" else f"{value[:80]!r} does not read as {target}"
            msg = (
                f"{layout.path}: {where(i)}, column {column!r}: {what} (the "
                f"column reads as {target} from the first rows); fix the value"
            )
            return InputError(msg)
    return InputError(f"{layout.path}: column {column!r}: cannot convert to {target}")


def _is_number(kind: Any) -> bool:
    return bool(
        pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)
    )


def _without_nulls(
    layout: TableLayout,
    name: str,
    values: Any,
    where: Callable[[int], str],
    needed: BoolArray | None,
) -> Any:
    """An integer or boolean pyarrow column's nulls filled, when no needed row has one.

    Raises
    ------
    InputError
        A null in a needed row, naming where it is (``where``) and its column.
    """
    nulls = np.asarray(values.is_null().to_numpy(zero_copy_only=False))
    if needed is not None:
        nulls &= needed
    if nulls.any():
        row = int(np.flatnonzero(nulls)[0])
        msg = (
            f"{layout.path}: {where(row)}, column {layout.file_name(name)!r}: no value "
            f"(null) in a {values.type} column, which this output cannot store as missing: "
            "fill it, or write a CSV or Parquet output (they keep nulls)"
        )
        raise InputError(msg)
    return pc.fill_null(values, pa.scalar(0).cast(values.type))


def numeric_columns(
    layout: TableLayout,
    columns: Mapping[str, Any],
    where: Callable[[int], str],
    needed: BoolArray | None = None,
) -> dict[str, np.ndarray[Any, Any]]:
    """The numeric (and boolean) columns of a slice, as numpy arrays.

    The columns a CSV slice gives as text are converted to the type pyarrow infers for
    them (``layout.inferred``); an empty cell of a float column becomes NaN. Columns
    inferred as text are left out. A pyarrow column keeps its type; a null becomes NaN
    in a float column, and is an error in an integer or boolean one (numpy has no
    missing integer: pyarrow would turn the column into floats, cast back to garbage).

    Parameters
    ----------
    layout : TableLayout
    columns : mapping of str to ndarray or pyarrow array, shape (M,)
        A slice as `read_table_slice` gives it (with ``arrow`` or without).
    where : callable of int to str
        Row ``i`` of the slice as a user finds it in the file (for messages:
        `kinsync.io.points.slice_position`).
    needed : ndarray of bool, shape (M,), optional
        The rows whose values are used (the others may hold nulls); default all.

    Raises
    ------
    InputError
        A cell that does not convert, a null in a needed row of an integer or boolean
        column (naming its line or row, and column).
    """
    out: dict[str, np.ndarray[Any, Any]] = {}
    for name, values in columns.items():
        arrow = isinstance(values, pa.Array | pa.ChunkedArray)
        if arrow and _is_number(values.type):
            filled = values
            if values.null_count and not pa.types.is_floating(values.type):
                filled = _without_nulls(layout, name, values, where, needed)
            out[name] = filled.to_numpy(zero_copy_only=False)
            continue
        if not arrow and values.dtype.kind in "biuf":
            out[name] = values
            continue
        target = layout.inferred.field(layout.file_name(name)).type if layout.inferred else None
        if target is None or not _is_number(target):
            continue
        if not arrow:
            text = pa.array(values, pa.string())
        elif pa.types.is_string(values.type):
            text = values.combine_chunks() if isinstance(values, pa.ChunkedArray) else values
        else:
            continue
        if pa.types.is_floating(target):
            text = pc.if_else(pc.equal(text, ""), "nan", text)
        try:
            out[name] = pc.cast(text, target).to_numpy(zero_copy_only=False)
        except (pa.ArrowException, ValueError) as err:
            cells = np.asarray(text.to_numpy(zero_copy_only=False))
            raise _cast_error(layout, name, cells, target, where) from err
    return out
