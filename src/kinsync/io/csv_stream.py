"""A CSV point table streamed by pyarrow in blocks of bounded size, whatever its width.

`kinsync.io.points.iter_table_chunks` reads CSV through `csv_batches` and regroups the
record batches into chunks of ``chunk_points`` rows.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.csv as pa_csv

from kinsync.errors import InputError
from kinsync.io.csv_cells import PARSE_ERROR, locate_bad_csv_cell

__all__ = ["STREAM_BLOCK_BYTES", "csv_batches"]

STREAM_BLOCK_BYTES = 1 << 24
"""Block of pyarrow's streaming CSV reader: it decodes blocks ahead on its threads, so
a block sized to a chunk (16 bytes x columns x chunk_points, 480 MB for 30 columns at the
default chunk) held gigabytes; `kinsync.io.points` puts chunks together from the blocks."""

_STRADDLING = "straddling object"  # pyarrow: a row longer than the block


def _csv_stream(
    path: Path, convert: Any, block_bytes: int, skip_rows: int, on_open: Callable[[Any], None]
) -> Generator[Any, None, None]:
    """Batches of pyarrow's streaming reader, the first ``skip_rows`` rows left out."""
    reader = None
    try:
        reader = pa_csv.open_csv(
            path, read_options=pa_csv.ReadOptions(block_size=block_bytes), convert_options=convert
        )
        on_open(reader)
        for batch in reader:
            if skip_rows >= batch.num_rows:
                skip_rows -= batch.num_rows
                continue
            yield batch.slice(skip_rows) if skip_rows else batch
            skip_rows = 0
    finally:
        # The streaming reader reads ahead on pyarrow's threads: left open when the
        # consumer stops (an error in a chunk, a generator dropped), the process can
        # abort at exit ("terminate called without an active exception").
        if reader is not None:
            reader.close()


def csv_batches(
    path: Path,
    required: Sequence[str],
    block_bytes: int,
    text: Sequence[str] = (),
    types: Mapping[str, Any] | None = None,
) -> Iterator[Any]:
    """Record batches of a CSV, in blocks of at most `STREAM_BLOCK_BYTES`.

    ``types`` fixes the other columns' types (those pyarrow inferred from a first block
    of ``block_bytes``). A row longer than the block is read by starting again, past
    the rows given, with blocks of ``block_bytes``, as every row shorter than that was.
    """
    convert = pa_csv.ConvertOptions(
        column_types=dict(types or {})
        | dict.fromkeys(required, pa.float64())
        | dict.fromkeys(text, pa.string()),
        null_values=[""],
        strings_can_be_null=False,
    )
    block = min(block_bytes, STREAM_BLOCK_BYTES)
    done = 0
    schema: list[Any] = []

    def fix_types(reader: Any) -> None:  # the retry converts as the first reader did
        if not schema:
            schema.append(reader.schema)

    try:
        while True:
            try:
                stream = _csv_stream(path, convert, block, done, fix_types)
                try:
                    for batch in stream:
                        done += batch.num_rows
                        yield batch
                finally:  # its reader closed now, whatever stopped the loop
                    stream.close()
                return
            except pa.ArrowInvalid as err:
                if _STRADDLING not in str(err) or block >= block_bytes:
                    raise
                block = block_bytes
                if schema:
                    convert.column_types = {f.name: f.type for f in schema[0]}
    except pa.ArrowInvalid as err:
        if PARSE_ERROR in str(err):
            bad = locate_bad_csv_cell(path, required)
            if bad is not None:
                raise bad from err
        if "conversion error" in str(err):
            bad = locate_bad_csv_cell(path, required)
            if bad is not None:
                raise bad from err
            msg = (
                f"{path}: {err}; a column's values change type after the first rows "
                "(types are inferred from the first block): make the column uniform"
            )
            raise InputError(msg) from err
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
    except (pa.ArrowException, OSError) as err:
        msg = f"{path}: cannot read as CSV ({err})"
        raise InputError(msg) from err
