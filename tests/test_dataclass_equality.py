"""No public dataclass of kinsync compares its arrays with a generated ``==``.

A dataclass with ``eq=True`` (the default) compares its fields as a tuple: with an array
field ``a == b`` raises numpy's "truth value of an array ... is ambiguous", and a frozen
one's ``hash`` raises TypeError. `ImuData`, `GnssData`, `NavSolution`, `MountEffect`,
`LineFit`, `LazChunks` and `CloudExtent` were such dataclasses. Containers and results
holding arrays compare by identity (``eq=False``), or define an ``__eq__`` of their own.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from tests._dataclasses import dataclasses_with_arrays

from kinsync.ins import GnssData, ImuData


def _dataclasses_with_arrays() -> dict[str, type]:
    return dataclasses_with_arrays()


def _generated_eq(cls: type) -> bool:
    """True when ``cls.__eq__`` is the one `dataclasses` wrote (compares the fields)."""
    params = cls.__dataclass_params__  # type: ignore[attr-defined]
    code = getattr(cls.__eq__, "__code__", None)
    return bool(params.eq) and code is not None and not code.co_filename.endswith(".py")


def test_no_dataclass_with_arrays_compares_them_field_by_field() -> None:
    found = _dataclasses_with_arrays()
    assert "kinsync.ins.measurements.ImuData" in found  # the scan sees the containers
    assert "kinsync.sync.mount_effect.MountEffect" in found
    offenders = sorted(name for name, cls in found.items() if _generated_eq(cls))
    assert offenders == [], f"give these eq=False (or an __eq__ of their own): {offenders}"


def test_containers_with_arrays_compare_and_hash_by_identity() -> None:
    t = np.arange(10, dtype=np.float64) * 0.01 + 1.4e9
    a = ImuData(t, np.zeros((10, 3)), np.tile([0.0, 0.0, -9.81], (10, 1)))
    b = ImuData(t, np.zeros((10, 3)), np.tile([0.0, 0.0, -9.81], (10, 1)))
    assert a == a  # noqa: PLR0124
    assert a != b
    assert len({a, b}) == 2
    g = GnssData(t, np.full(10, 46.8), np.full(10, -71.2), np.zeros(10), np.full((10, 3), 0.02))
    assert g != dataclasses.replace(g)
    assert hash(g) == hash(g)
