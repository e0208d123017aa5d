"""The files of rejected points beside a georeferenced output: their names, stale ones.

`rejected_path_for` names the file a run's points outside the trajectory span go to;
`remove_stale_rejected` removes those an earlier run left beside the output, so that the
files beside it always hold exactly this run's points.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from kinsync.errors import InputError
from kinsync.io.atomic import ProtectedInput, check_not_an_input
from kinsync.io.sanity import is_file_there

__all__ = [
    "LAS_SUFFIXES",
    "TABLE_SUFFIXES",
    "point_file_kind",
    "rejected_path_for",
    "remove_stale_rejected",
]

LAS_SUFFIXES = (".las", ".laz")
TABLE_SUFFIXES = (".csv", ".parquet")


def rejected_path_for(out_path: Path, points_path: Path | None = None) -> Path:
    """``OUT.rejected.<ext>``: where points outside the trajectory span go.

    They are written unchanged (as records or columns of the input): ``<ext>`` is the output's
    suffix when input and output are of one kind (LAS/LAZ, or CSV/Parquet tables):
    ``geo.laz`` rejects to ``geo.rejected.laz``. Else it is the input's, after the
    output's whole name (a LAZ georeferenced to ``geo.csv`` rejects to
    ``geo.csv.rejected.laz``), so that runs to ``geo.csv`` and ``geo.las`` from one CSV
    input never share, replace or remove each other's rejected file.
    """
    out_path = Path(out_path)
    if points_path is not None and point_file_kind(Path(points_path)) != point_file_kind(out_path):
        return out_path.with_name(f"{out_path.name}.rejected{Path(points_path).suffix}")
    return out_path.with_name(f"{out_path.stem}.rejected{out_path.suffix}")


def point_file_kind(path: Path) -> str:
    """``"las"`` (.las, .laz), ``"ply"`` or ``"table"`` (.csv, .parquet, and any other)."""
    suffix = path.suffix.lower()
    return "las" if suffix in LAS_SUFFIXES else "ply" if suffix == ".ply" else "table"


def _rejected_files_for(out_path: Path) -> list[Path]:
    """The existing files beside ``out_path`` that `rejected_path_for` gives for some input.

    ``OUT.rejected.<ext>`` with the output's suffix (an input of the output's kind), and
    ``OUT.<ext>.rejected.<ext2>`` for an input of another kind (``<ext2>`` spelled as
    that input's suffix was).
    """
    found = []
    if point_file_kind(out_path) != "ply":  # no input is a PLY file
        found.append(rejected_path_for(out_path))
    prefix = f"{out_path.name}.rejected"
    with contextlib.suppress(OSError):
        for name in sorted(p.name for p in out_path.parent.iterdir()):
            suffix = name[len(prefix) :].lower()
            if (
                name.startswith(prefix)
                and suffix in LAS_SUFFIXES + TABLE_SUFFIXES
                and point_file_kind(Path(name)) != point_file_kind(out_path)
            ):
                found.append(out_path.parent / name)
    return [p for p in found if is_file_there(p)]  # a name too long is no file


def remove_stale_rejected(
    out_path: Path, points_path: Path, trajectory_path: Path, written: Path | None
) -> list[str]:
    """Remove every ``OUT.rejected.<ext>`` an earlier run left beside ``out_path``.

    Whatever the earlier run's input format (`_rejected_files_for`), but ``written``,
    this run's own rejected file. Left beside the new output, its points would be
    counted with it and the counts would no longer add up. A file that is one of the
    inputs is never removed.
    """
    inputs = (
        ProtectedInput(points_path, "--points"),
        ProtectedInput(trajectory_path, "--trajectory"),
    )
    why = (
        f"this run's rejected points are in {written}" if written else "this run rejected no points"
    )
    notes = []
    for stale in [p for p in _rejected_files_for(out_path) if p != written]:
        try:
            check_not_an_input(stale, inputs)
        except InputError:
            continue
        try:
            stale.unlink()
        except OSError as err:
            notes.append(
                f"{stale}: left by an earlier run, could not be removed ({err}); {why}: delete it"
            )
            continue
        notes.append(f"{stale}: removed, left by an earlier run; {why}")
    return notes
