"""Array and mapping helpers shared by the containers (results never change)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import Any, TypeVar

import numpy as np

from kinsync._typing import ArrayLike, FloatArray

__all__ = ["FrozenMapping", "readonly_array"]

_K = TypeVar("_K")
_V = TypeVar("_V")


class FrozenMapping(Mapping[_K, _V]):
    """A read-only mapping that pickles, copies and hashes, for frozen results.

    ``types.MappingProxyType`` is read-only too, but cannot be pickled, deep-copied or
    hashed, and neither could a result holding one. Equal to any mapping with the same
    items; hashable when its values are.

    Parameters
    ----------
    items : mapping or iterable of (key, value), optional
        The items (copied).
    """

    __slots__ = ("_items",)

    def __init__(self, items: Mapping[_K, _V] | Iterable[tuple[_K, _V]] = ()) -> None:
        self._items: dict[_K, _V] = dict(items)

    def __getitem__(self, key: _K) -> _V:
        return self._items[key]

    def __iter__(self) -> Iterator[_K]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __hash__(self) -> int:
        return hash(frozenset(self._items.items()))

    def __reduce__(self) -> tuple[Any, tuple[dict[_K, _V]]]:
        return (type(self), (self._items,))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._items!r})"


def readonly_array(values: ArrayLike, *, copy: bool = True) -> FloatArray:
    """``values`` as a read-only, C-contiguous float64 array (containers hold these).

    With ``copy=False`` an array that already is contiguous float64 is flagged read-only
    in place instead of copied: only for arrays the caller has just made and owns.
    """
    if copy:
        out = np.array(values, dtype=np.float64, copy=True, order="C")
    else:
        out = np.ascontiguousarray(values, dtype=np.float64)
    out.setflags(write=False)
    return out
