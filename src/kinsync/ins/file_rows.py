"""How the INS checks name a row of an input: its data row and, from a file, its line.

The checks (`kinsync.ins.checks`, `kinsync.ins.alignment`) see containers, whose rows
count from 0; a user opens the file in an editor, which numbers lines from 1 (a CSV's
header is line 1). `FileRows` carries what the caller knows of the file: the line of a
data row, and the data row that holds the container's first row (the GNSS epochs
before the IMU span are cut off before filtering, `kinsync.ins.checks.gnss_within_imu_span`).
Without one, messages name the container's rows as before (``row 5``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = ["MAX_LISTED", "FileRows", "rows_list"]

MAX_LISTED = 5
"""Rows a message lists before it says how many there are in all."""


@dataclass(frozen=True)
class FileRows:
    """The file rows and lines of a container's rows, for messages.

    Attributes
    ----------
    line_of_row : callable or None
        ``line_of_row(r)``: the file line (1-based) of the file's data row ``r``
        (0-based); None: messages give rows only.
    first_row : int
        The file's data row that holds the container's row 0.
    """

    line_of_row: Callable[[int], int] | None = None
    first_row: int = 0

    def row(self, k: int) -> str:
        """``"5 (line 7)"``: the file's data row of the container's row ``k``, and its line.

        Parameters
        ----------
        k : int
            Row of the container (0-based).

        Returns
        -------
        str
            The data row of the file, with its line when known.
        """
        line = self.line(k)
        return f"{int(k) + self.first_row}" + ("" if line is None else f" (line {line})")

    def line(self, k: int) -> int | None:
        """The file line of the container's row ``k``, or None when not known.

        Parameters
        ----------
        k : int
            Row of the container (0-based).

        Returns
        -------
        int or None
            The 1-based line.
        """
        return None if self.line_of_row is None else self.line_of_row(int(k) + self.first_row)

    def where(self, k: int) -> str:
        """``"row 5, line 7"``: the container's row ``k`` as a place in the file.

        Parameters
        ----------
        k : int
            Row of the container (0-based).

        Returns
        -------
        str
            ``row R`` or ``row R, line L``.
        """
        line = self.line(k)
        return f"row {int(k) + self.first_row}" + ("" if line is None else f", line {line}")


def rows_list(rows: Sequence[int], names: FileRows | None = None) -> str:
    """The first `MAX_LISTED` rows, each with its line, and the count beyond them.

    Parameters
    ----------
    rows : sequence of int
        Rows of the container (0-based).
    names : FileRows, optional
        The file rows and lines; default: the rows as they are.

    Returns
    -------
    str
        ``"596 (line 598), 597 (line 599), ... (90 in all)"``.
    """
    namer = names or FileRows()
    shown = ", ".join(namer.row(r) for r in rows[:MAX_LISTED])
    return shown + (f", ... ({len(rows)} in all)" if len(rows) > MAX_LISTED else "")
