"""The public dataclasses of kinsync that hold arrays, found by walking its packages."""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil

import kinsync

ARRAY_TYPES = ("Array", "ndarray")
"""Annotations that hold arrays: FloatArray, IntArray, BoolArray, ArrayLike, np.ndarray..."""


def dataclasses_with_arrays(
    *, skip_prefixes: tuple[str, ...] = (), frozen_only: bool = False
) -> dict[str, type]:
    """Public dataclasses with an array field, by dotted name (``__main__`` never imported).

    Parameters
    ----------
    skip_prefixes : tuple of str
        Module names starting with these are left out.
    frozen_only : bool
        Only frozen dataclasses.
    """
    found: dict[str, type] = {}
    for info in pkgutil.walk_packages(kinsync.__path__, "kinsync."):
        skipped = bool(skip_prefixes) and info.name.startswith(skip_prefixes)
        if info.name.endswith("__main__") or skipped:
            continue  # __main__ runs the command line
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if (
                isinstance(obj, type)
                and dataclasses.is_dataclass(obj)
                and obj.__module__ == module.__name__
                and not name.startswith("_")
                and (not frozen_only or obj.__dataclass_params__.frozen)  # type: ignore[attr-defined]
                and any(
                    kind in str(f.type) for f in dataclasses.fields(obj) for kind in ARRAY_TYPES
                )
            ):
                found[f"{module.__name__}.{name}"] = obj
    return found
