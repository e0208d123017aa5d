"""Suite-wide collection order: the files with long-running tests first.

``make test`` runs the suite on two workers, a whole file at a time (``--dist
loadfile``: a file's module fixtures, such as a Monte Carlo's runs, are computed once).
A worker takes the next file when it is done with one, so a file that takes minutes and
comes last keeps one worker busy while the other has nothing left: in collection order
the README and scale-factor files ran at the end, and one worker finished about three
minutes before the other. Files holding a test marked ``slow`` are therefore collected
first (in their usual order, and so is everything else), and the short files fill the
two workers to the end.
"""

from __future__ import annotations

import pytest

SOURCE_DATE_EPOCH = "1700000000"
"""2023-11-14 UTC: the creation date of every LAS/LAZ the tests write (tests that
compare two outputs byte for byte failed when the two runs fell either side of
midnight UTC); tests of the date itself remove or change it."""


@pytest.fixture(autouse=True)
def _fixed_creation_date(monkeypatch: pytest.MonkeyPatch) -> None:
    """``SOURCE_DATE_EPOCH`` for every test, its subprocesses included."""
    monkeypatch.setenv("SOURCE_DATE_EPOCH", SOURCE_DATE_EPOCH)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Move the files with a ``slow`` test to the front; the order is otherwise kept."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: False sorts first
