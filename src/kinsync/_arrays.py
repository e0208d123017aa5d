"""Array and mapping helpers shared by the containers (results never change)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import Any, TypeVar

import numpy as np

from kinsync._typing import ArrayLike, FloatArray

__all__ = ["FrozenMapping", "ReadOnlyArrays", "readonly_array"]

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


class ReadOnlyArrays:
    """Base of the frozen containers: their read-only arrays stay read-only in copies.

    numpy pickles an array without its flags, so a container unpickled or deep-copied
    (``pickle``, ``copy.deepcopy``, a worker process) would hold writeable arrays that
    could be changed after the container checked them (times no longer increasing,
    say). The state records which arrays were read-only, directly or as items of a
    tuple, and `__setstate__` flags those arrays of the copy read-only again; writeable
    arrays stay writeable.
    """

    __slots__ = ()

    def __getstate__(self) -> tuple[dict[str, Any], tuple[tuple[str, int], ...]]:
        state = dict(vars(self))
        frozen: list[tuple[str, int]] = []
        for name, value in state.items():
            if _is_read_only(value):
                frozen.append((name, -1))
            elif isinstance(value, tuple):
                frozen.extend((name, i) for i, item in enumerate(value) if _is_read_only(item))
        return state, tuple(frozen)

    def __setstate__(self, state: tuple[dict[str, Any], tuple[tuple[str, int], ...]]) -> None:
        values, frozen = state
        vars(self).update(values)
        for name, index in frozen:
            value = values[name]
            (value if index < 0 else value[index]).setflags(write=False)


def _is_read_only(value: object) -> bool:
    return isinstance(value, np.ndarray) and not value.flags.writeable


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
