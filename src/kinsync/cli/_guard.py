"""Rules every command obeys: no output replaces an input; numbers are finite and sane.

`guard_commands` wraps every command of the program. Each ``Path`` parameter of a
command is an input, except those named in `OUTPUT_PARAMETERS`. Before the command
runs, each output is checked against the other outputs (two options naming one file)
and against each input (`kinsync.io.atomic.check_not_an_input`:
the same file by any path, an input folder, a file inside one); while it runs, every
file written (all go through `kinsync.io.atomic.atomic_path`) is checked again, so a
figure or report written into an input folder cannot replace an input either. Each
output's location is checked too (`kinsync.io.atomic.check_output_location`): a file
output that is an existing folder, a missing folder, a folder where nothing can be
written are refused before any work. A command drawing figures has matplotlib's folder
checked then too (`kinsync.report._mpl_folder`): none writable, not even a temporary
one, is refused before any output is written.

Each ``int`` or ``float`` parameter, and each value of a repeatable one, must be
finite and inside its span in `kinsync.cli._bounds.OPTION_BOUNDS`, checked before the
command starts.
"""

from __future__ import annotations

import functools
import inspect
import types
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import typer

from kinsync.cli._bounds import check_numeric_option
from kinsync.cli._help import reflowed
from kinsync.cli._streams import OutputPipeClosed, output_pipe_closed
from kinsync.errors import InputError
from kinsync.io.atomic import (
    ProtectedInput,
    check_not_an_input,
    check_output_location,
    named_outputs,
    protected_inputs,
)
from kinsync.io.sanity import check_name_length

__all__ = [
    "OUTPUT_PARAMETERS",
    "guard_commands",
    "numeric_parameters",
    "output_is_folder",
    "path_parameters",
]

OUTPUT_PARAMETERS = frozenset({"out", "model_out", "mount_out", "figure", "png", "report"})
"""Names of the ``Path`` parameters that are outputs (files or folders) of a command."""

OUTPUT_SUFFIXES = {
    "model_out": ".json",
    "mount_out": ".toml",
    "figure": ".png",
    "png": ".png",
    "report": ".html",
}
"""The one format each of these outputs is written in: another suffix is refused (a PNG
written into ``figure.jpg`` or JSON into ``model.toml`` misleads whatever opens it)."""

FIGURE_PARAMETERS = frozenset({"figure", "png", "report"})
"""Outputs drawn with matplotlib (the HTML report holds figures)."""

FOLDER_OUTPUT_COMMANDS = ("simulate ", "demo")
"""Commands (prefixes of their full names) whose ``--out`` is a folder, not a file."""


def output_is_folder(command: str, name: str) -> bool:
    """Whether output parameter ``name`` of ``command`` ("simulate drive") is a folder."""
    return name == "out" and command.startswith(FOLDER_OUTPUT_COMMANDS)


def _is_path_type(hint: Any) -> bool:
    if hint is Path:
        return True
    origin = typing.get_origin(hint)
    if origin is typing.Annotated:
        return _is_path_type(typing.get_args(hint)[0])
    if origin in (list, tuple, typing.Union, types.UnionType):
        return any(_is_path_type(a) for a in typing.get_args(hint))
    return False


def _option_name(name: str, hint: Any) -> str:
    """The command-line spelling of parameter ``name`` (``--in`` for ``in_path``)."""
    for meta in getattr(hint, "__metadata__", ()):
        # In Annotated, typer.Option("--in") keeps the name as its "default".
        first = getattr(meta, "default", None)
        decls = [
            *(getattr(meta, "param_decls", None) or ()),
            *([first] if isinstance(first, str) else []),
        ]
        longs = [d for d in decls if d.startswith("--")]
        if longs:
            return str(longs[0])
        if isinstance(meta, typer.models.ArgumentInfo):
            return name.upper()
    return "--" + name.replace("_", "-")


def path_parameters(callback: Callable[..., Any]) -> dict[str, str]:
    """``{parameter name: option spelling}`` of the ``Path`` parameters of a command."""
    hints = typing.get_type_hints(callback, include_extras=True)
    return {
        name: _option_name(name, hint)
        for name, hint in hints.items()
        if name != "return" and _is_path_type(hint)
    }


def _is_number_type(hint: Any) -> bool:
    if typing.get_origin(hint) is typing.Annotated:
        return _is_number_type(typing.get_args(hint)[0])
    if hint is bool:
        return False
    if hint in (int, float):
        return True
    # A repeatable option (list[float]) is checked value by value.
    if typing.get_origin(hint) in (typing.Union, types.UnionType, list, tuple):
        return any(_is_number_type(a) for a in typing.get_args(hint))
    return False


def _numbers(value: Any) -> Iterator[int | float]:
    """The numbers of an option's value: itself, or each value of a repeated option."""
    if isinstance(value, bool):
        return
    if isinstance(value, int | float):
        yield value
    elif isinstance(value, list | tuple):
        for v in value:
            yield from _numbers(v)


def numeric_parameters(callback: Callable[..., Any]) -> dict[str, str]:
    """``{parameter name: option spelling}`` of the ``int``/``float`` parameters.

    Repeatable options (``list[float]``) count: each of their values is checked.
    """
    hints = typing.get_type_hints(callback, include_extras=True)
    return {
        name: _option_name(name, hint)
        for name, hint in hints.items()
        if name != "return" and _is_number_type(hint)
    }


def _paths(value: Any) -> Iterator[Path]:
    if isinstance(value, Path):
        yield value
    elif isinstance(value, list | tuple):
        for v in value:
            yield from _paths(v)


def _check_suffix(path: Path, option: str, suffix: str | None) -> None:
    """Refuse an output whose suffix is not the one format it is written in."""
    if suffix is not None and path.suffix.lower() != suffix:
        msg = f"{option} {path}: this output is {suffix[1:].upper()}; give a {suffix} file"
        raise InputError(msg)


def _check_not_another_output(path: Path, option: str, outputs: list[tuple[str, Path]]) -> None:
    """Refuse an output that is the same file as another output of the command.

    Both would be written and the later one would replace the earlier (a report written
    over the calibrated mount, a figure over the clock model).
    """
    where = path.resolve()
    for other_option, other in outputs:
        if other.resolve() == where:
            msg = (
                f"{option} {path} and {other_option} {other} are the same file: one would "
                "replace the other; give each its own file"
            )
            raise InputError(msg)


def _guard(callback: Callable[..., Any], command: str) -> Callable[..., Any]:
    spelled = path_parameters(callback)
    numbers = numeric_parameters(callback)
    signature = inspect.signature(callback)

    @functools.wraps(callback)
    def guarded(*args: Any, **kwargs: Any) -> Any:
        bound = signature.bind(*args, **kwargs)
        for name, option in numbers.items():
            for value in _numbers(bound.arguments.get(name)):
                check_numeric_option(command, option, value)
        inputs = [
            ProtectedInput(p, _input_label(spelled[name], p))
            for name, value in bound.arguments.items()
            if name in spelled and name not in OUTPUT_PARAMETERS
            for p in _paths(value)
        ]
        for name, value in bound.arguments.items():
            if name in spelled:
                for p in _paths(value):
                    check_name_length(p, _shown(spelled[name], p))
        outputs: list[tuple[str, Path]] = []
        given_outputs: set[str] = set()
        for name, value in bound.arguments.items():
            if name in spelled and name in OUTPUT_PARAMETERS:
                for p in _paths(value):
                    given_outputs.add(name)
                    check_not_an_input(p, inputs, spelled[name])
                    _check_not_another_output(p, spelled[name], outputs)
                    _check_suffix(p, spelled[name], OUTPUT_SUFFIXES.get(name))
                    outputs.append((spelled[name], p))
                    folder = output_is_folder(command, name)
                    check_output_location(p, spelled[name], folder=folder)
                    if folder and command.startswith("simulate "):
                        from kinsync.sim.folder import check_simulation_folder  # noqa: PLC0415

                        check_simulation_folder(p, command.removeprefix("simulate "))
        if command == "demo" or any(name in FIGURE_PARAMETERS for name in given_outputs):
            # before any output is written: matplotlib may need a folder of its own
            from kinsync.report._mpl_folder import prepare_matplotlib_folder  # noqa: PLC0415

            prepare_matplotlib_folder()
        with protected_inputs(inputs), named_outputs(outputs):
            try:
                return callback(*args, **kwargs)
            except BrokenPipeError as err:
                # stdout's reader left (| head -1); click would end with status 1, silent
                if output_pipe_closed():
                    raise OutputPipeClosed(str(err)) from err
                raise

    return guarded


def _shown(spelled: str, path: Path) -> str:
    """``--mount m.toml`` for an option; the path alone for an argument."""
    return f"{spelled} {path}" if spelled.startswith("-") else str(path)


def _input_label(spelled: str, path: Path) -> str:
    """``--mount m.toml`` for an option; ``FOLDER (tbl)`` for an argument."""
    return f"{spelled} {path}" if spelled.startswith("-") else f"{spelled} ({path})"


def guard_commands(app: typer.Typer, prefix: tuple[str, ...] = ()) -> None:
    """Wrap every command of ``app`` and of its groups (recursively) in the rules."""
    for info in app.registered_commands:
        if info.callback is not None and not hasattr(info.callback, "__wrapped__"):
            name = info.name or info.callback.__name__
            if info.help is None and info.callback.__doc__:
                info.help = reflowed(info.callback.__doc__)
            info.callback = _guard(info.callback, " ".join((*prefix, name)))
    for group in app.registered_groups:
        if group.typer_instance is not None:
            guard_commands(group.typer_instance, (*prefix, str(group.name)))
