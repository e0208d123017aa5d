"""The public Python API: each package's names, loaded lazily, documented.

A library user imports ``from kinsync.ins import run_ins``; the ``kinsync`` program
imports ``kinsync.ins.config`` at start-up and must not load the filter (numba) for it.
"""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys
from types import ModuleType

import pytest

PACKAGES = (
    "kinsync",
    "kinsync.calibration",
    "kinsync.clock",
    "kinsync.errors",
    "kinsync.fit",
    "kinsync.georef",
    "kinsync.ins",
    "kinsync.latency",
    "kinsync.sync",
    "kinsync.validation",
)


def _module(name: str) -> ModuleType:
    return importlib.import_module(name)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_resolves_and_is_listed(package: str) -> None:
    module = _module(package)
    names = getattr(module, "__all__", None)
    assert names, f"{package} has no __all__"
    assert len(set(names)) == len(names)
    listed = dir(module)
    for name in names:
        obj = getattr(module, name)
        assert name in listed, f"{package}.{name} missing from dir()"
        if inspect.isclass(obj) or inspect.isfunction(obj):
            assert obj.__module__.startswith("kinsync"), f"{package}.{name} is {obj.__module__}'s"


@pytest.mark.parametrize("package", ["kinsync.calibration", "kinsync.ins", "kinsync.latency"])
def test_an_unknown_name_is_an_attribute_error(package: str) -> None:
    with pytest.raises(AttributeError, match=r"has no attribute 'run_everything'"):
        _module(package).run_everything  # noqa: B018


def test_package_names_load_their_modules_on_first_use() -> None:
    code = (
        "import sys, kinsync.ins.config, kinsync.latency.passes, kinsync.calibration.lines\n"
        "before = {m for m in ('kinsync.ins.filter', 'kinsync.latency.sphere', "
        "'kinsync.calibration.estimator') if m in sys.modules}\n"
        "from kinsync.ins import run_ins\n"
        "from kinsync.latency import estimate_latency_sphere\n"
        "print(sorted(before), 'kinsync.ins.filter' in sys.modules, "
        "'kinsync.latency.sphere' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out == ["[]", "True", "True"]


DOCUMENTED_MODULES = (
    *PACKAGES,
    "kinsync.frames",
    "kinsync.trajectory",
    "kinsync.mount",
    "kinsync.crs",
    "kinsync.budget",
)


def _public_callables(module: ModuleType) -> dict[str, object]:
    """Each function in ``__all__`` and each public method of each class in it, by name.

    Keyed ``module.qualname`` where defined, so a name exported by several packages
    appears once. Static and class methods count as methods; properties do not.
    """
    out: dict[str, object] = {}
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isfunction(obj):
            found = [obj]
        elif inspect.isclass(obj):
            found = []
            for attr, value in vars(obj).items():
                if attr.startswith("_"):
                    continue
                func = value.__func__ if isinstance(value, staticmethod | classmethod) else value
                if inspect.isfunction(func):
                    found.append(func)
        else:
            continue
        for func in found:
            out[f"{func.__module__}.{func.__qualname__}"] = func
    return out


def _takes_arguments(func: object) -> bool:
    assert callable(func)
    return any(p not in ("self", "cls") for p in inspect.signature(func).parameters)


def test_public_functions_and_methods_document_their_parameters() -> None:
    # DESIGN.md: numpy docstrings, each parameter with shape, unit and frame.
    found: dict[str, object] = {}
    for package in DOCUMENTED_MODULES:
        found.update(_public_callables(_module(package)))
    assert len(found) > 100  # the walk reached the API, not an empty __all__
    offenders = sorted(
        name
        for name, func in found.items()
        if _takes_arguments(func) and "Parameters\n" not in (inspect.getdoc(func) or "")
    )
    assert not offenders, (
        f"{len(offenders)} public functions or methods take arguments but have no numpy "
        "'Parameters' section in their docstring:\n" + "\n".join(offenders)
    )
