"""Command lines for tests that vary one option of a base command."""

from __future__ import annotations

from collections.abc import Sequence


def with_options(base: Sequence[str], extra: Sequence[str]) -> list[str]:
    """``base`` with ``extra`` appended, each option of ``extra`` taken out of ``base``.

    kinsync refuses an option that takes one value given twice, so a test that changes
    one of the base command's options replaces it rather than repeating it. Options of
    ``base`` are followed by one value each.
    """
    names = {token for token in extra if token.startswith("--")}
    out: list[str] = []
    skip = False
    for token in base:
        if skip:
            skip = False
            continue
        if token in names:
            skip = True
            continue
        out.append(token)
    return [*out, *extra]
