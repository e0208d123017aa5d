"""How the report writes numbers: a value with its σ, a p-value.

One place for the rules, so every table, figure and verdict of a report writes the
same quantity the same way.
"""

from __future__ import annotations

import math

__all__ = ["format_p_value", "format_value", "plus_minus"]

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


def _decimals_for(sigma: float) -> int:
    """Decimals that show the second significant digit of ``sigma``."""
    return max(0, 1 - math.floor(math.log10(sigma)))


def plus_minus(value: float, std: float) -> str:
    """``value ± std`` with both rounded to the second significant digit of ``std``."""
    if not (math.isfinite(value) and math.isfinite(std)) or std <= 0.0:
        return f"{value:.4g} ± {std:.2g}"
    decimals = _decimals_for(std)
    return f"{value:.{decimals}f} ± {std:.{decimals}f}"


def format_value(value: float, sigma: float | None = None, unit: str = "") -> str:
    """A measured value, with its σ when there is one, and its unit.

    With a σ: both rounded to the σ's second significant digit (``0.0017 ± 0.016 ms``);
    without: three significant digits (``8.74 mm``; no exponent from 100 up), integers
    as they are.

    Parameters
    ----------
    value : float
        The value (NaN is written ``not available``).
    sigma : float, optional
        Its standard deviation, same unit.
    unit : str
        Appended after a space when not empty.
    """
    if not math.isfinite(value):
        text = "not available" if math.isnan(value) else f"{value}"
    elif sigma is not None:
        text = plus_minus(value, sigma)
    elif float(value).is_integer() and abs(value) < 1e6:
        text = f"{int(value)}"
    elif abs(value) >= 100.0:
        text = f"{value:.0f}"
    else:
        text = f"{value:.3g}"
    return f"{text} {unit}" if unit else text
