"""Errors raised by kinsync.

Every error a user can cause is a :class:`KinsyncError`; the command-line program
catches this one base class, prints its message on one line and exits with status 2.
Messages say what was wrong, where (file, column, row or time) and what to do.

What kinsync does differently from what was asked, without failing (velocities it will
not use, data an output cannot carry), is a :class:`KinsyncWarning`: the program prints
each on one line, ``kinsync: warning: ...``, on stderr.
"""

from __future__ import annotations

import re

__all__ = [
    "ConvergenceError",
    "DiskFullError",
    "InputError",
    "KinsyncError",
    "KinsyncWarning",
    "ObservabilityError",
    "OutsideSpanError",
    "PeriodPriorError",
    "PointValueError",
    "plain_values",
]

_NUMPY_REPR = re.compile(
    r"(?P<quoted>(?<!\w)'(?:[^'\\\n]|\\.)*'(?!\w))"  # a quoted text: the user's, kept
    r"|np\.(?:float|int|uint|complex|longdouble|str_|bytes_)(?:8|16|32|64|128|256)?"
    r"\((?P<value>[^()]*)\)"
    r"|np\.(?P<bool>True|False)_"
)


def _plain(match: re.Match[str]) -> str:
    if match["quoted"] is not None:
        return match[0]
    return match["value"] if match["value"] is not None else match["bool"]


def plain_values(text: str) -> str:
    """``text`` with numpy scalar reprs as their plain values: ``np.float64(1.5)`` -> ``1.5``.

    numpy 2 writes ``np.float64(1.5)`` for ``repr`` (and ``!r`` in an f-string) of a
    scalar taken from an array; a message shows a value as a user writes it. Quoted
    text (``'...'``, a cell or a line of the user's file) is left as it is.

    Parameters
    ----------
    text : str
        A message, as formatted.

    Returns
    -------
    str
        The message with each ``np.float64(...)``-style repr (float, int, uint,
        complex, longdouble, str_, bytes_) outside quoted text replaced by the value
        inside the parentheses, and ``np.True_``/``np.False_`` by ``True``/``False``.
    """
    return _NUMPY_REPR.sub(_plain, text)


class KinsyncError(Exception):
    """Base class of every error kinsync raises on purpose.

    A message's numpy scalar reprs are shown as plain values (`plain_values`), however
    the message was formatted.
    """

    def __init__(self, *args: object) -> None:
        super().__init__(*(plain_values(a) if isinstance(a, str) else a for a in args))


class InputError(KinsyncError, ValueError):
    """Input data or parameters are invalid (bad value, shape, file content)."""


class DiskFullError(InputError):
    """A full disk, disk quota or file-size limit stopped an output; nothing partial is left."""


class PointValueError(InputError):
    """A bad value in arrays of points; the first one located by its 0-based index.

    Algorithms see arrays, not files: they name the point by its index. A pipeline that
    read the points from a file names it as the file counts it (a CSV line, a Parquet
    row, a LAS point) from these attributes.

    Attributes
    ----------
    index : int
        The first bad point, 0-based in the arrays given.
    count : int
        Bad points (of this kind) in the arrays given.
    field : str
        The value that is bad: ``"t"`` (the point time), ``"x"``, ``"y"``, ``"z"``
        (scanner-frame coordinates) or ``"range_m"``, ``"angle_rad"`` (profile).
    problem : str
        What is wrong with it, without its place (``"nan is not finite"``).
    advice : str
        What to do.
    """

    def __init__(
        self, message: str, *, index: int, count: int, field: str, problem: str, advice: str
    ) -> None:
        super().__init__(message)
        self.index = index
        self.count = count
        self.field = field
        self.problem = plain_values(problem)
        self.advice = advice


class OutsideSpanError(InputError):
    """A time lies outside the span of a time series and would need extrapolation."""


class PeriodPriorError(InputError):
    """A profiler's period prior excludes the clock the data show (Method B).

    Attributes
    ----------
    period_prior_s : float
        The prior (s).
    n_within : int
        Sightings matched by the best clock with a period within the prior's tolerance.
    n_sightings : int
        Sightings found in the scan.
    suggested_period_s : float
        Period (s) of the clock that matches more sightings, ``n_suggested``.
    n_suggested : int
        Sightings that clock matches.
    """

    def __init__(
        self,
        message: str,
        *,
        period_prior_s: float,
        n_within: int,
        n_sightings: int,
        suggested_period_s: float,
        n_suggested: int,
    ) -> None:
        super().__init__(message)
        self.period_prior_s = period_prior_s
        self.n_within = n_within
        self.n_sightings = n_sightings
        self.suggested_period_s = suggested_period_s
        self.n_suggested = n_suggested


class ConvergenceError(KinsyncError):
    """An iterative estimator did not converge."""


class ObservabilityError(KinsyncError):
    """The data do not determine the requested quantity (degenerate geometry)."""


class KinsyncWarning(UserWarning):
    """Base class of the warnings kinsync issues on purpose (one line each on the CLI)."""
