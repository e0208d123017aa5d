"""Names a package exports without importing their modules until first used (PEP 562).

``from kinsync.ins import run_ins`` works, and ``import kinsync.ins.config`` (what the
``kinsync`` program does at start-up) does not load the filter, numba or scipy: a
package's ``__init__`` lists its public names here and imports them for type checkers
only (``if TYPE_CHECKING:``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, names: Mapping[str, str], *, submodules: bool = False
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose names load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : mapping of str to str
        Each exported name and the module that defines it.
    submodules : bool
        Also give a submodule as an attribute on first use (``kinsync.trajectory``
        after ``import kinsync``).

    Returns
    -------
    tuple of (callable, callable)
        The module's ``__getattr__`` and ``__dir__``.
    """

    def module_getattr(name: str) -> Any:
        module = names.get(name)
        if module is not None:
            return getattr(importlib.import_module(module), name)
        if submodules and not name.startswith("_"):
            try:
                return importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as err:
                if err.name != f"{package}.{name}":
                    raise
        msg = f"module {package!r} has no attribute {name!r}"
        raise AttributeError(msg)

    def module_dir() -> list[str]:
        module = importlib.import_module(package)
        return sorted({*vars(module), *names})

    return module_getattr, module_dir
