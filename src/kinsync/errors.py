"""Errors raised by kinsync.

Every error a user can cause is a :class:`KinsyncError`; the command-line program
catches this one base class, prints its message on one line and exits with status 2.
Messages say what was wrong, where (file, column, row or time) and what to do.

What kinsync does differently from what was asked, without failing (velocities it will
not use, data an output cannot carry), is a :class:`KinsyncWarning`: the program prints
each on one line, ``kinsync: warning: ...``, on stderr.
"""

from __future__ import annotations


class KinsyncError(Exception):
    """Base class of every error kinsync raises on purpose."""


class InputError(KinsyncError, ValueError):
    """Input data or parameters are invalid (bad value, shape, file content)."""


class OutsideSpanError(InputError):
    """A time lies outside the span of a time series and would need extrapolation."""


class ConvergenceError(KinsyncError):
    """An iterative estimator did not converge."""


class ObservabilityError(KinsyncError):
    """The data do not determine the requested quantity (degenerate geometry)."""


class KinsyncWarning(UserWarning):
    """Base class of the warnings kinsync issues on purpose (one line each on the CLI)."""
