"""Kernels compile without a cache where numba finds no writable cache folder.

Installed in a root-owned ``site-packages`` with a read-only ``HOME`` (and no writable
``NUMBA_CACHE_DIR``), importing any module with a ``cache=True`` kernel failed with
``RuntimeError: cannot cache function '_georef_loop': no locator available``: exit 1
on every command. numba's lookup of a cache folder is made to fail here by giving it
no locator to try, as a read-only install leaves it none that works.
"""

from __future__ import annotations

import importlib.util
import multiprocessing
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from numba.core import config
from numba.core.caching import CacheImpl

from kinsync import _jit
from kinsync._jit import NO_CACHE_WARNING, cached_njit, jit_cache_enabled
from kinsync.errors import KinsyncWarning

SRC = Path(__file__).resolve().parents[1] / "src" / "kinsync"


@pytest.fixture
def no_cache_folder(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(CacheImpl, "_locator_classes", [])
    monkeypatch.setattr(config, "CACHE_LOCATOR_CLASSES", "")  # NUMBA_CACHE_LOCATOR_CLASSES
    monkeypatch.setitem(_jit._STATE, "uncached", 0)


def _twice(x: float) -> float:  # pragma: no cover - numba
    return 2.0 * x


@pytest.mark.usefixtures("no_cache_folder")
def test_the_setup_makes_numba_fail() -> None:
    from numba import njit  # noqa: PLC0415

    with pytest.raises(RuntimeError, match="no locator available"):
        njit(cache=True)(_twice)


@pytest.mark.usefixtures("no_cache_folder")
def test_a_kernel_compiles_without_a_cache_and_warns_once() -> None:
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        first = cached_njit(nogil=True)(_twice)
        second = cached_njit()(_twice)
    assert first(1.5) == 3.0
    assert second(2.0) == 4.0
    assert [(w.category, str(w.message)) for w in seen] == [(KinsyncWarning, NO_CACHE_WARNING)]
    assert "NUMBA_CACHE_DIR" in NO_CACHE_WARNING
    assert not jit_cache_enabled()


@pytest.mark.usefixtures("no_cache_folder")
def test_a_kernel_module_imports_without_a_cache_folder() -> None:
    # a fresh copy of the module, under another name: the imported one is left alone
    spec = importlib.util.spec_from_file_location(
        "kinsync_las_coordinates_copy", SRC / "io" / "las_coordinates.py"
    )
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        spec.loader.exec_module(module)
    assert [str(w.message) for w in seen] == [NO_CACHE_WARNING]
    out = np.empty((1, 3))
    xyz = np.array([1, 2, 3], dtype=np.int32)
    module._scale_into(xyz[:1], xyz[1:2], xyz[2:], np.ones(3), np.zeros(3), out)
    assert out.tolist() == [[1.0, 2.0, 3.0]]


def test_a_writable_cache_folder_is_used() -> None:
    kernel = cached_njit()(_twice)
    assert getattr(kernel, "_cache", None).__class__.__name__ == "FunctionCache"


def test_every_kernel_goes_through_cached_njit() -> None:
    direct = re.compile(r"\bnjit\(\s*cache\s*=\s*True")
    found = {
        path.relative_to(SRC).as_posix()
        for path in SRC.rglob("*.py")
        if path.name != "_jit.py" and direct.search(path.read_text(encoding="utf-8"))
    }
    assert not found, f"use kinsync._jit.cached_njit instead: {sorted(found)}"


@pytest.mark.usefixtures("no_cache_folder")
def test_a_pool_worker_does_not_warn(monkeypatch: pytest.MonkeyPatch) -> None:
    # the main process warns; a worker's warning would reach stderr in Python's format
    monkeypatch.setattr(multiprocessing.current_process(), "_name", "SpawnProcess-1")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        kernel = cached_njit()(_twice)
    assert kernel(1.0) == 2.0
    assert seen == []
