"""Where the demo looks for the outside reference data (NaveGo, CIDCO).

The sets live in ``../shared/data`` beside a checkout of kinsync (`README`). The demo
looks, in this order, in the folder ``KINSYNC_REFERENCE_DATA`` names (a folder holding
``navego-synthetic`` and ``cidco-port-de-quebec``, for an installed kinsync or data kept
elsewhere), in ``../shared/data`` beside the working folder, and in ``../shared/data``
beside the checkout this code runs from. An installed package is no checkout: its
folder's ``../shared`` means nothing and is not searched (nor shown in the report).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["REFERENCE_DATA_VARIABLE", "reference_candidates"]

REFERENCE_DATA_VARIABLE = "KINSYNC_REFERENCE_DATA"
"""Environment variable naming a folder of reference sets (one sub-folder per set)."""

_SHARED = Path("..") / "shared" / "data"


def _checkout_root() -> Path | None:
    """The checkout this code runs from (``<root>/src/kinsync/demo``), or None if installed."""
    here = Path(__file__).resolve()
    return here.parents[3] if here.parents[2].name == "src" else None


def reference_candidates(set_name: str) -> list[Path]:
    """The folders where the reference set ``set_name`` is looked for, in order.

    Parameters
    ----------
    set_name : str
        The set's folder name, e.g. ``navego-synthetic``.

    Returns
    -------
    list of Path
        ``$KINSYNC_REFERENCE_DATA/<set_name>`` when the variable is set, then
        ``../shared/data/<set_name>`` beside the working folder and beside the checkout
        (when this code runs from one); normalised, without repeats.
    """
    found = []
    named = os.environ.get(REFERENCE_DATA_VARIABLE, "").strip()
    if named:
        found.append(Path(named).expanduser().absolute() / set_name)
    found.append(Path.cwd() / _SHARED / set_name)
    root = _checkout_root()
    if root is not None:
        found.append(root / _SHARED / set_name)
    return list(dict.fromkeys(Path(os.path.normpath(c)) for c in found))
