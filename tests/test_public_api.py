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
