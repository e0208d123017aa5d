"""Counted nouns for messages, tables and figure labels ("1 pass", "2 passes")."""

from __future__ import annotations

__all__ = ["counted"]

_IRREGULAR = {"pass": "passes", "axis": "axes", "matrix": "matrices", "patch": "patches"}


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` followed by ``noun`` in the number that ``n`` needs.

    Parameters
    ----------
    n : int
        The count.
    noun : str
        The singular noun ("pass", "point", "line").
    plural : str, optional
        The plural when it is neither in the irregular table nor ``noun + "s"``.

    Returns
    -------
    str
        ``"1 pass"``, ``"0 passes"``, ``"12 points"``.
    """
    if n == 1:
        return f"1 {noun}"
    return f"{n} {plural or _IRREGULAR.get(noun) or noun + 's'}"
