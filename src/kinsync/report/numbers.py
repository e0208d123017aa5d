"""How the report writes numbers: a value with its σ, a p-value.

One place for the rules, so every table, figure and verdict of a report writes the
same quantity the same way.
"""

from __future__ import annotations

import math

from kinsync._text import P_CEILING, P_FLOOR, format_p_value

__all__ = ["P_CEILING", "P_FLOOR", "format_p_value", "format_value", "plus_minus"]


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
