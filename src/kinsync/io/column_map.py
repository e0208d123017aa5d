"""Column mapping for point tables: kinsync's column names -> the names in a user's file.

A point table need not use kinsync's names: ``--columns t_s=time,x_m=X,y_m=Y,z_m=Z``
reads the file's ``time`` column as ``t_s`` and so on. `parse_column_map` checks the
text of the option against the names the command knows; `ColumnMap.check_file` checks
it against a file's header (every mapped column present, no unmapped column of the
file already carrying a name the map gives to another). The table readers
(`kinsync.io.points`) read the file's own columns and hand them on under kinsync's
names; writers that carry the input's columns give them back their own names
(`ColumnMap.file_name`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from kinsync.errors import InputError

__all__ = ["ColumnMap", "parse_column_map"]

_ITEM = re.compile(r"^\s*([^=\s][^=]*?)\s*=\s*([^=]*?)\s*$")


@dataclass(frozen=True)
class ColumnMap:
    """Which column of a user's table holds each kinsync column.

    Attributes
    ----------
    pairs : tuple of (str, str)
        ``(kinsync name, the file's column name)``, each kinsync name and each file
        column at most once.
    flag : str
        The option that gave the map, for messages (``"--columns"``).
    """

    pairs: tuple[tuple[str, str], ...] = ()
    flag: str = "--columns"

    def file_name(self, name: str) -> str:
        """The file's column for kinsync column ``name`` (``name`` itself when unmapped)."""
        return next((theirs for ours, theirs in self.pairs if ours == name), name)

    def kinsync_name(self, column: str) -> str:
        """The kinsync name of the file's column ``column`` (itself when unmapped)."""
        return next((ours for ours, theirs in self.pairs if theirs == column), column)

    def renames(self) -> tuple[tuple[str, str], ...]:
        """``(file column, kinsync name)`` of every mapping that renames."""
        return tuple((theirs, ours) for ours, theirs in self.pairs if ours != theirs)

    def text(self) -> str:
        """The map as the option's text (``t_s=time,x_m=X``)."""
        return ",".join(f"{ours}={theirs}" for ours, theirs in self.pairs)

    def hint(self, missing: Sequence[str]) -> str:
        """How to map ``missing`` kinsync columns, for a missing-column message."""
        example = ",".join(f"{name}=YOUR_COLUMN" for name in missing)
        return f"rename the file's columns, or map yours with {self.flag} {example}"

    def check_file(self, path: Path, names: Sequence[str]) -> None:
        """Check the map against a file's column names (in file order).

        Raises
        ------
        InputError
            A mapped column the file does not have (listing those it has), or an
            unmapped column of the file that already has a kinsync name the map gives
            to another column.
        """
        for ours, theirs in self.pairs:
            if theirs not in names:
                msg = (
                    f"{path}: {self.flag} maps {ours} to column {theirs!r}, which the file "
                    f"does not have; its columns are {list(names)}: fix {self.flag}"
                )
                raise InputError(msg)
        mapped = {theirs for _, theirs in self.pairs}
        for ours, theirs in self.pairs:
            if ours != theirs and ours in names and ours not in mapped:
                msg = (
                    f"{path}: has a column {ours!r} of its own, and {self.flag} "
                    f"{ours}={theirs} reads column {theirs!r} as {ours}: two columns would "
                    f"carry that name; drop {ours}={theirs} or rename the file's {ours!r}"
                )
                raise InputError(msg)

    def kinsync_names(self, names: Sequence[str]) -> list[str]:
        """The file's column names as the readers hand them on (mapped ones renamed)."""
        return [self.kinsync_name(n) for n in names]


def parse_column_map(text: str | None, known: Sequence[str], flag: str = "--columns") -> ColumnMap:
    """Parse ``KINSYNC=COLUMN[,KINSYNC=COLUMN...]`` into a `ColumnMap`.

    Parameters
    ----------
    text : str or None
        The option's value; None or blank gives an empty map.
    known : sequence of str
        The kinsync column names the command reads (``t_s``, ``x_m``, ...).
    flag : str
        The option's name, for messages.

    Raises
    ------
    InputError
        An item that is not ``NAME=COLUMN``, an unknown kinsync name (listing the
        known ones), a kinsync name mapped twice, a file column given for two kinsync
        names.
    """
    if text is None or not text.strip():
        return ColumnMap((), flag)
    example = f"{flag} {known[0]}=time" if known else f"{flag} NAME=COLUMN"
    pairs: list[tuple[str, str]] = []
    for item in text.split(","):
        match = _ITEM.match(item)
        if match is None or not match.group(2):
            msg = (
                f"{flag}: {item.strip()!r} is not KINSYNC_NAME=YOUR_COLUMN; give "
                f"comma-separated pairs, kinsync's name on the left, e.g. {example}"
            )
            raise InputError(msg)
        ours, theirs = match.group(1), match.group(2)
        if ours not in known:
            msg = (
                f"{flag}: {ours!r} is not a column kinsync reads here; map one of "
                f"{', '.join(known)} (kinsync's name on the left, your file's column on "
                f"the right, e.g. {example})"
            )
            raise InputError(msg)
        for seen_ours, seen_theirs in pairs:
            if seen_ours == ours:
                msg = (
                    f"{flag}: {ours} is mapped twice ({seen_theirs!r} and {theirs!r}); "
                    "map each kinsync column once"
                )
                raise InputError(msg)
            if seen_theirs == theirs:
                msg = (
                    f"{flag}: your column {theirs!r} is given for both {seen_ours} and "
                    f"{ours}; map each of your columns to one kinsync column"
                )
                raise InputError(msg)
        pairs.append((ours, theirs))
    return ColumnMap(tuple(pairs), flag)
