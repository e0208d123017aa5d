"""numba's ``njit(cache=True)``, falling back to no cache where nothing can be cached.

numba caches a compiled kernel beside its module (``__pycache__``), in
``NUMBA_CACHE_DIR`` or in the user's cache folder (``~/.cache/numba``). Where none is
writable (kinsync installed in a root-owned ``site-packages``, a read-only ``HOME``, a
read-only ``NUMBA_CACHE_DIR``), ``njit(cache=True)`` raises ``RuntimeError: cannot
cache function ...: no locator available`` when the module is imported. `cached_njit`
compiles such a kernel without a cache instead (every run compiles it again) and warns
once, saying how to keep the compiled code (in the main process only: the workers of
``--scheduler processes`` compile their kernels too, and their warnings would reach
stderr in Python's own format).
"""

from __future__ import annotations

import multiprocessing
import warnings
from collections.abc import Callable
from typing import Any

from numba import njit

from kinsync.errors import KinsyncWarning

__all__ = ["NO_CACHE_WARNING", "cached_njit", "jit_cache_enabled"]

NO_CACHE_WARNING = (
    "numba finds no writable folder to cache kinsync's compiled code in (the package's "
    "__pycache__, NUMBA_CACHE_DIR or ~/.cache/numba), so every run compiles it again "
    "(seconds); set NUMBA_CACHE_DIR to a writable folder to save that time"
)
"""The warning given, once, when a kernel is compiled without a cache."""

_NO_LOCATOR = "no locator available"
"""What numba's ``RuntimeError`` says when no cache folder is writable."""

_STATE = {"uncached": 0}
"""How many kernels were compiled without a cache in this process."""


def _in_main_process() -> bool:
    """Whether this is the main process, not a pool worker importing a kernel.

    A spawned or forkserver worker is named ("SpawnProcess-1") before it unpickles its
    task and so imports the kernels; ``parent_process()`` is set only after that.
    """
    return multiprocessing.current_process().name == "MainProcess"


def jit_cache_enabled() -> bool:
    """Whether every kernel compiled so far by `cached_njit` is cached on disk.

    Returns
    -------
    bool
        False once a kernel had to be compiled without a cache (no writable folder).
    """
    return _STATE["uncached"] == 0


def cached_njit(**options: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``numba.njit(cache=True, **options)``, without the cache where none can be written.

    Parameters
    ----------
    **options : Any
        numba's other options (``nogil``, ``fastmath``, ...).

    Returns
    -------
    callable
        A decorator compiling a function as ``njit`` does. Where numba finds no
        writable cache folder for the function's module, the function is compiled
        without a cache and a `KinsyncWarning` says, once, to set ``NUMBA_CACHE_DIR``.
    """

    def decorate(func: Callable[..., Any]) -> Callable[..., Any]:
        try:
            return njit(cache=True, **options)(func)  # type: ignore[no-any-return]
        except RuntimeError as err:
            if _NO_LOCATOR not in str(err):
                raise
        if _STATE["uncached"] == 0 and _in_main_process():
            warnings.warn(NO_CACHE_WARNING, KinsyncWarning, stacklevel=3)
        _STATE["uncached"] += 1
        return njit(cache=False, **options)(func)  # type: ignore[no-any-return]

    return decorate
