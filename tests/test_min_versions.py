"""pyproject.toml's lower bounds and .ci/min-versions.txt, the pins that check them, agree.

`make test-min` installs the pins and runs the whole suite on them; a bound raised or
lowered in pyproject.toml without its pin would leave the bound untested.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
CHECKED_EXTRAS = ("scale", "test")  # not dev: linters judge typing, with the newest numpy
_PIN = re.compile(r"^(?P<name>[A-Za-z0-9._-]+)==(?P<version>\S+)\s*(?:#\s*(?P<why>.+))?$")


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def lower_bounds(pyproject: dict[str, object]) -> dict[str, Version]:
    """Each dependency's ``>=`` bound: [project] dependencies and the checked extras."""
    project = pyproject["project"]
    assert isinstance(project, dict)
    lines = list(project["dependencies"])
    for extra in CHECKED_EXTRAS:
        lines += project["optional-dependencies"][extra]
    bounds: dict[str, Version] = {}
    for line in lines:
        req = Requirement(line)
        if _canonical(req.name) == "kinsync":
            continue  # kinsync[...]: another extra
        lows = [Version(s.version) for s in req.specifier if s.operator == ">="]
        assert len(lows) == 1, f"{line!r}: give exactly one lower bound (>=)"
        bounds[_canonical(req.name)] = lows[0]
    return bounds


def pins(text: str) -> dict[str, tuple[Version, str | None]]:
    """``name==version  # why`` lines: version and the reason a pin is above its bound."""
    out: dict[str, tuple[Version, str | None]] = {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        match = _PIN.match(line)
        assert match, f"min-versions.txt line {number}: {raw!r} is not 'name==version'"
        name = _canonical(match["name"])
        assert name not in out, f"min-versions.txt line {number}: {name} pinned twice"
        out[name] = (Version(match["version"]), match["why"])
    return out


def disagreements(
    bounds: dict[str, Version], pinned: dict[str, tuple[Version, str | None]]
) -> list[str]:
    """What does not agree, one line each (empty when the pins are the bounds)."""
    problems = [f"{n}>={b}: no pin" for n, b in bounds.items() if n not in pinned]
    problems += [f"{n}: pinned but not a bounded dependency" for n in pinned if n not in bounds]
    for name, (version, why) in pinned.items():
        bound = bounds.get(name)
        if bound is None:
            continue
        if version < bound:
            problems.append(f"{name}=={version} is below the bound >={bound}")
        elif version > bound and not why:
            problems.append(f"{name}=={version} is above the bound >={bound} with no reason")
    return problems


def _pyproject(dependencies: list[str]) -> dict[str, object]:
    extras: dict[str, list[str]] = {extra: [] for extra in CHECKED_EXTRAS}
    return {"project": {"dependencies": dependencies, "optional-dependencies": extras}}


def test_every_lower_bound_has_its_pin() -> None:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    text = (ROOT / ".ci" / "min-versions.txt").read_text(encoding="utf-8")
    assert disagreements(lower_bounds(pyproject), pins(text)) == []


@pytest.mark.parametrize(
    ("deps", "text", "expected"),
    [
        (["numpy>=1.26"], "numpy==1.26.0\n", []),
        (["numpy>=1.26"], "numpy==1.26\n", []),
        (["numpy>=1.27"], "numpy==1.26.0\n", ["numpy==1.26.0 is below the bound >=1.27"]),
        (
            ["numpy>=1.26"],
            "numpy==1.26.4\n",
            ["numpy==1.26.4 is above the bound >=1.26 with no reason"],
        ),
        (["scipy>=1.11"], "scipy==1.11.1  # 1.11.0 is yanked\n", []),
        (["numpy>=1.26", "rich>=13"], "numpy==1.26.0\n", ["rich>=13: no pin"]),
        (
            ["numpy>=1.26"],
            "numpy==1.26.0\nrich==13.0\n",
            ["rich: pinned but not a bounded dependency"],
        ),
        (["laspy[lazrs]>=2.5"], "laspy==2.5.0\n", []),
        (["Typing_Extensions>=4"], "typing-extensions==4.0\n", []),
    ],
)
def test_the_check_finds_each_disagreement(deps: list[str], text: str, expected: list[str]) -> None:
    pyproject = _pyproject(deps)
    assert disagreements(lower_bounds(pyproject), pins(text)) == expected


@pytest.mark.parametrize("dep", ["numpy", "numpy<2", "numpy>=1.26,>=1.27"])
def test_a_dependency_needs_one_lower_bound(dep: str) -> None:
    pyproject = _pyproject([dep])
    with pytest.raises(AssertionError, match="exactly one lower bound"):
        lower_bounds(pyproject)
