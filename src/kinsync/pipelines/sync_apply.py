"""Method B applied to a scan file: every return time-tagged and put in the scanner frame.

`apply_profile_clock` streams a scan table in chunks, gives each return its time from
the profile clock (`kinsync.clock.profile.ProfileClock`) and its scanner-frame
coordinates from the mount's profiler azimuth (`kinsync.mount.Mount.profile_to_scanner`),
and writes every input column plus ``t_s,x_m,y_m,z_m`` atomically, ready for
``kinsync georef --points``.

The columns it does not use are carried as georef carries them: a Parquet scan's with
their Arrow types and nulls (an integer column with nulls stays integers, a null is an
empty cell in a CSV output), a CSV scan's as their text, byte for byte. The columns it
uses keep a Parquet scan's number types (``profile`` int32 stays int32); a CSV scan's
``profile`` is written as integers (profile numbers are whole), its angles and ranges as
floats. A Parquet output keeps the run's kinsync record in its schema metadata
(`kinsync.io.point_provenance`: the mount, its file, the scan and the clock); a CSV has
nowhere to keep it.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from kinsync._typing import FloatArray
from kinsync.clock.profile import ProfileClock
from kinsync.errors import InputError, KinsyncWarning
from kinsync.georef.kernel import MAX_SCANNER_RANGE_M
from kinsync.io.point_provenance import file_document, parquet_record_metadata, point_document
from kinsync.io.points import (
    TableChunkWriter,
    count_table_rows,
    iter_table_chunks,
    table_columns,
)
from kinsync.io.row_position import point_position
from kinsync.io.sanity import require_file
from kinsync.mount import MAX_PROFILE_ANGLE_RAD, Mount
from kinsync.sync.scan import PROFILE_SCANNER_REACH_M, ProfileScan, long_range_note

__all__ = ["APPLY_COLUMNS", "apply_profile_clock"]

APPLY_COLUMNS = ("t_s", "x_m", "y_m", "z_m")
"""Columns `apply_profile_clock` adds: time (s) and scanner-frame coordinates (m)."""


def _stored_number_types(path: Path, required: Sequence[str]) -> dict[str, Any]:
    """A Parquet scan's integer, float32 or float64 type of each required column.

    The reader hands required columns on as float64; cast back to the type they were
    stored in they are exactly the stored values. Empty for a CSV (no stored types);
    columns stored as anything else (text holding numbers, decimals) are left out.
    """
    if path.suffix.lower() != ".parquet":
        return {}
    schema = pq.read_schema(path)  # read already by the first chunk: the file is Parquet
    kinds = {name: schema.field(name).type for name in required}
    return {
        name: kind
        for name, kind in kinds.items()
        if pa.types.is_integer(kind) or kind in (pa.float32(), pa.float64())
    }


def _refuse_output_columns(path: Path, names: Iterable[str]) -> None:
    """An `InputError` when the scan already has a column that apply adds."""
    clash = [c for c in APPLY_COLUMNS if c in names]
    if clash:
        msg = (
            f"{path}: already has column(s) {clash}; rename them, sync apply "
            f"adds {list(APPLY_COLUMNS)}"
        )
        raise InputError(msg)


def _empty_output(path: Path, required: Sequence[str]) -> dict[str, Any]:
    """The output columns of a scan without data rows, typed as a full chunk's would be.

    Written so that a header-only scan gives a valid header-only table (CSV) or an
    empty table with every column (Parquet), as ``kinsync georef`` does, not an empty
    file: every input column (a CSV's carried ones as text, a Parquet scan's with their
    types), ``profile`` whole, then ``t_s,x_m,y_m,z_m``.
    """
    if path.suffix.lower() == ".parquet":
        kinds = {f.name: f.type for f in pq.read_schema(path)}
    else:
        kinds = dict.fromkeys(table_columns(path), pa.string())
    _refuse_output_columns(path, kinds)
    stored = _stored_number_types(path, required)
    for name in required:
        kinds[name] = stored.get(name, pa.int64() if name == "profile" else pa.float64())
    kinds |= dict.fromkeys(APPLY_COLUMNS, pa.float64())
    return {name: pa.array([], type=kind) for name, kind in kinds.items()}


def _checked_ranges(
    scan_path: Path, phi: FloatArray, rng_m: FloatArray, where: Callable[[int], str]
) -> tuple[int, int, int]:
    """Refuse a chunk's bad angle or range; count its zero and very long ranges.

    Parameters
    ----------
    scan_path : Path
        The scan, for messages.
    phi, rng_m : ndarray, shape (N,)
        Mirror angles (rad) and ranges (m) of the chunk.
    where : callable
        ``where(i)`` names the chunk's row ``i`` in the file.

    Returns
    -------
    tuple of int
        Index of the first zero range (-1 for none), the number of zero ranges (a
        "no return" code, refused by the caller once counted) and of ranges beyond
        `PROFILE_SCANNER_REACH_M`.

    Raises
    ------
    InputError
        An angle beyond one turn, a range negative, not finite or beyond
        `MAX_SCANNER_RANGE_M`, naming the first such row.
    """
    bad = ~(
        (np.abs(phi) <= MAX_PROFILE_ANGLE_RAD)  # False for NaN
        & (rng_m >= 0.0)
        & (rng_m <= MAX_SCANNER_RANGE_M)
    )
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        msg = (
            f"{scan_path}: {where(row)}: angle_rad {float(phi[row])!r}, "
            f"range_m {float(rng_m[row])!r}: a range is a finite distance, above 0 up to "
            f"{MAX_SCANNER_RANGE_M:.0f} m, and a mirror angle radians within one turn "
            "(+-2 pi); fix or remove the row"
        )
        raise InputError(msg)
    zero = np.flatnonzero(rng_m == 0.0)  # such a return would lie at the scanner itself
    first = int(zero[0]) if zero.size else -1
    return first, int(zero.size), int(np.count_nonzero(rng_m > PROFILE_SCANNER_REACH_M))


def _checked_clock(t0_s: float, period_s: float, mount: Mount) -> ProfileClock:
    """The profile clock, once the mount has a profiler azimuth and the clock is sound."""
    if mount.profiler_azimuth_deg is None:
        msg = (
            "mount: no [profiler] azimuth_deg; the scanner-frame coordinates of a profile "
            "need the profile plane's azimuth: add a [profiler] table with azimuth_deg"
        )
        raise InputError(msg)
    if not (math.isfinite(t0_s) and math.isfinite(period_s) and period_s > 0.0):
        msg = f"clock: t0_s must be finite and period_s > 0, got {t0_s!r}, {period_s!r}"
        raise InputError(msg)
    return ProfileClock(t0_s, period_s)


def apply_profile_clock(
    scan_path: Path,
    out_path: Path,
    t0_s: float,
    period_s: float,
    mount: Mount,
    *,
    chunk_points: int = 1_000_000,
    progress: Callable[[int], None] | None = None,
    mount_file: Path | None = None,
    clock_file: Path | None = None,
) -> int:
    """Time-tag a scan and put its returns in the scanner frame, streaming in chunks.

    Each return gets ``t_s = t0_s + (profile + angle_rad / 2 pi) period_s`` and
    ``(x_m, y_m, z_m) = Rz(azimuth) (0, r sin phi, r cos phi)`` (the mount's
    ``[profiler] azimuth_deg``), appended after every input column (all kept, with
    their types and nulls: see the module docstring), ready for ``kinsync georef
    --points``. A scan without data rows gives a table without rows but with every
    column (a CSV header line), as ``kinsync georef`` gives for a table without points.

    Parameters
    ----------
    scan_path : Path
        Scan table (``.csv`` / ``.parquet``) with ``profile,angle_rad,range_m``.
    out_path : Path
        Output table (``.csv`` / ``.parquet``), written atomically.
    t0_s, period_s : float
        The profile clock (s).
    mount : Mount
        Needs ``[profiler] azimuth_deg``.
    chunk_points : int
        Rows per chunk.
    progress : callable, optional
        Called with the number of rows done after each chunk.
    mount_file, clock_file : Path, optional
        The files ``mount`` and the clock were read from, named in a Parquet output's
        kinsync record (`kinsync.io.point_provenance`) with their SHA-256.

    Returns
    -------
    int
        Rows written.

    Raises
    ------
    InputError
        A mount without ``[profiler]``, a bad clock, an input that already has one of
        the output columns, bad profile numbers, an empty cell or null in ``profile``,
        ``angle_rad`` or ``range_m`` (naming the CSV line or Parquet row, and column),
        a range of 0 (a "no return" code: the first and the count), unreadable files.

    Warns
    -----
    KinsyncWarning
        More than half of the ranges lie beyond `PROFILE_SCANNER_REACH_M` (millimetres?).
    """
    clock = _checked_clock(t0_s, period_s, mount)
    scan_path = Path(scan_path)
    required = ("profile", "angle_rad", "range_m")
    done = 0
    n_zero, first_zero, n_long = 0, -1, 0  # zero ranges (refused), ranges beyond 2 km
    last_profile = 0.0
    require_file(scan_path, "scan")  # a link loop, a pipe: named as such, as a scan
    csv = scan_path.suffix.lower() == ".csv"
    total = None if csv else count_table_rows(scan_path)  # Parquet: "row N of M"

    def where(row: int) -> str:
        """Data row ``row`` (0-based) as a user finds it: CSV line, Parquet row of all."""
        return point_position(scan_path, row, total)

    def from_row(first: int) -> Callable[[int], str]:
        """``where`` for an array whose value 0 is data row ``first``."""
        return lambda i: where(first + i)

    stored: dict[str, Any] = {}
    chunks = iter_table_chunks(scan_path, chunk_points, required, extra_as_text=True, arrow=True)
    record = point_document(
        "sync apply",
        mount,
        mount_file,
        {
            "points": {"path": str(scan_path)},
            "clock": {
                "t0_s": t0_s,
                "period_s": period_s,
                "file": None if clock_file is None else file_document(Path(clock_file)),
            },
        },
    )
    with TableChunkWriter(Path(out_path), metadata=parquet_record_metadata(record)) as writer:
        for chunk in chunks:
            if done == 0:
                stored = _stored_number_types(scan_path, required)
            _refuse_output_columns(scan_path, chunk)
            before = [] if done == 0 else [last_profile]  # the order checked across chunks
            first = done - len(before)  # the file's data row of the array's first value
            profile = ProfileScan.checked_profile_numbers(
                np.concatenate([before, chunk["profile"]]),
                str(scan_path),
                from_row(first),
            )[len(before) :]
            last_profile = float(chunk["profile"][-1])
            phi = chunk["angle_rad"]
            rng_m = chunk["range_m"]
            zero_at, zeros, longs = _checked_ranges(scan_path, phi, rng_m, from_row(done))
            first_zero = first_zero if first_zero >= 0 or zero_at < 0 else done + zero_at
            n_zero, n_long = n_zero + zeros, n_long + longs
            xyz = (
                mount.profile_to_scanner(angle_rad=phi, range_m=rng_m) + 0.0
            )  # -0.0 written as 0.0
            out = dict(chunk) | {"profile": profile}  # whole numbers (checked)
            out |= {n: pa.array(chunk[n]).cast(t) for n, t in stored.items()}
            out["t_s"] = clock.time_s(chunk["profile"], phi)
            out["x_m"], out["y_m"], out["z_m"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            writer.write(out)
            done += phi.size
            if progress is not None:
                progress(done)
        if n_zero:  # refused once all are counted; the writer then discards its output
            msg = (
                f"{scan_path}: {where(first_zero)}: range_m is 0 ({n_zero:,} of {done:,} "
                "returns): a zero range, a common 'no return' code, would put the return "
                "at the scanner itself; remove the rows with range 0 and run again"
            )
            raise InputError(msg)
        if done == 0:  # no data rows: the output still gets its header or columns
            writer.write(_empty_output(scan_path, required))
    if long_range_note(n_long, done):
        warnings.warn(f"{scan_path}: {long_range_note(n_long, done)}", KinsyncWarning, stacklevel=2)
    return done
