"""How counts, p-values and lists of names read everywhere ("1 pass", "p < 0.001").

One place for terminal tables, messages, figures and reports alike.
"""

from __future__ import annotations

import math

__all__ = [
    "P_CEILING",
    "P_FLOOR",
    "counted",
    "first_few",
    "format_p_value",
    "reads_as_number",
    "shown_value",
]

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


def first_few(names: list[str], n: int = 3) -> str:
    """The first ``n`` names, comma-separated, and ``, ...`` when there are more."""
    return ", ".join(names[:n]) + (", ..." if len(names) > n else "")


SHOWN_VALUE_CHARS = 80
"""Most characters of a value a message repeats (`shown_value`)."""


def shown_value(value: object, limit: int = SHOWN_VALUE_CHARS) -> str:
    """A value as a message repeats it: its ``repr``, cut to ``limit`` characters.

    A value read from a file may be a list of 200,000 numbers or a 1 MB string: a
    message repeats its start, then ``...``, never the whole of it.

    Parameters
    ----------
    value : object
        The value at fault.
    limit : int
        Most characters of its ``repr`` kept.

    Returns
    -------
    str
        ``[1.0, 2.0]``, ``'abc'``; ``[1.0, 1.0, 1.0, ...`` when cut.
    """
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


P_FLOOR = 0.001
"""Below this a p-value is written ``p < 0.001``: more digits say nothing more."""

P_CEILING = 0.99
"""Above this a p-value is written ``p > 0.99``."""


def format_p_value(p: float, *, prefix: bool = True) -> str:
    """A p-value as a reader expects it: ``p < 0.001``, ``p = 0.004``, ``p = 0.79``.

    Below 0.001 the value is written as a bound (``p < 0.001``), from 0.001 to 0.01 with
    three decimals, from 0.01 with two, and above 0.99 as ``p > 0.99``.

    Parameters
    ----------
    p : float
        The p-value, in [0, 1]; NaN where the test could not be made.
    prefix : bool
        Write ``p = 0.04`` (True) or ``0.04`` (False, for a table column headed
        "p-value"; the bounds keep their sign: ``< 0.001``).

    Returns
    -------
    str
        ``p not available`` (or ``n/a``) for NaN.

    Raises
    ------
    ValueError
        ``p`` is outside [0, 1].
    """
    if math.isnan(p):
        return "p not available" if prefix else "n/a"
    if not 0.0 <= p <= 1.0:
        msg = f"a p-value lies in [0, 1], got {p!r}"
        raise ValueError(msg)
    if p < P_FLOOR:
        body = f"< {P_FLOOR:g}"
    elif p > P_CEILING:
        body = f"> {P_CEILING:g}"
    else:
        text = f"{p:.3f}" if p < 0.01 else f"{p:.2f}"
        body = f"= {text}" if prefix else text
    return f"p {body}" if prefix else body


def reads_as_number(text: str) -> bool:
    """Whether Python's ``float`` reads ``text`` (a CSV cell, a header field) as a number.

    Parameters
    ----------
    text : str
        The text (``"1.5"``, ``" 2 "``, ``"nan"``, ``"1_000"`` read; ``"t_s"`` does not).
    """
    try:
        float(text)
    except ValueError:
        return False
    return True
