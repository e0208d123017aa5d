"""Every command of the program, for tests generated from the commands themselves."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from kinsync.cli.app import app

EXTRA_REQUIRED: dict[tuple[str, ...], list[str]] = {
    ("validate", "flatness"): ["--box", "0,0,0,1,1,1"]
}
"""Required options that are not paths, for the commands that have some."""


def commands(
    typer_app: Any = app, prefix: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], Callable[..., Any]]]:
    for info in typer_app.registered_commands:
        yield (*prefix, info.name), info.callback
    for group in typer_app.registered_groups:
        yield from commands(group.typer_instance, (*prefix, group.name))
