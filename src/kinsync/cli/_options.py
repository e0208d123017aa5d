"""Option parsers shared by several commands."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

from kinsync.errors import InputError

__all__ = [
    "GPS_WEEK_SPAN_HELP",
    "MAX_GAP_HELP",
    "MULTI_VALUE_OPTIONS",
    "MaxGapOpt",
    "expand_multi_value_options",
    "parse_rates",
    "refuse_repeated_options",
]

MAX_GAP_HELP = (
    "Longest trajectory record interval (s) to interpolate across; times inside a longer "
    "one (a data gap) are treated as outside the trajectory's span. Default: 10 times the "
    "median record interval; the most, 86400 (a day), interpolates across any interval up "
    "to a day."
)
"""The help of ``--max-gap-s``, one wording for every command that reads a trajectory."""

GPS_WEEK_SPAN_HELP = (
    "A full GPS week number, 1024 or more (counted from 6 January 1980; a receiver's "
    "10-bit week plus 2048 since April 2019), up to two years after the current week."
)
"""What ``--gps-week`` accepts (`kinsync.cli._bounds`), appended to each command's help;
its typer option declares no range, so that a smaller week gets the bounds' message
about 10-bit week numbers."""

MaxGapOpt = Annotated[float | None, typer.Option("--max-gap-s", help=MAX_GAP_HELP)]
"""``--max-gap-s``: the gap threshold (s) of `kinsync.trajectory_gaps.max_gap_for`."""

MULTI_VALUE_OPTIONS: dict[tuple[str, ...], tuple[str, ...]] = {
    ("calibrate", "mount"): ("--points", "--trajectory"),
}
"""Options of a command that take several values after one flag (``--points lines/*.laz``)."""


def _command_path(args: Sequence[str], depth: int) -> tuple[str, ...]:
    return tuple(a for a in args if not a.startswith("-"))[:depth]


def expand_multi_value_options(args: Sequence[str]) -> list[str]:
    """``--points A B C`` -> ``--points A --points B --points C`` where a command allows it.

    typer (click) takes one value per option flag; a shell glob gives many. For the
    commands in `MULTI_VALUE_OPTIONS`, every token after such a flag up to the next
    token starting with ``-`` is one more value of it.
    """
    out = list(args)
    for path, names in MULTI_VALUE_OPTIONS.items():
        if _command_path(args, len(path)) != path:
            continue
        out = []
        current: str | None = None
        for token in args:
            if token.startswith("-"):
                current = token if token in names else None
                out.append(token)
            elif current is not None and out[-1] != current:
                out.extend([current, token])
            else:
                out.append(token)
        return out
    return out


def _leaf(command: Any, args: Sequence[str]) -> tuple[Any, int] | None:
    """The subcommand ``args`` name and the index of its first own argument.

    Duck-typed on click's command tree (``commands`` of a group): typer builds it with
    click, or with its own copy of click from 0.22 on.
    """
    i = 0
    while isinstance(getattr(command, "commands", None), dict):
        while i < len(args) and args[i].startswith("-"):
            i += 1  # the group's own options (--version, --help)
        if i >= len(args):
            return None
        sub = command.commands.get(args[i])
        if sub is None:
            return None  # click names the unknown command
        command, i = sub, i + 1
    return command, i


def _value_options(leaf: Any) -> tuple[dict[str, str], set[str]]:
    """Every value-taking option's names -> its first name; those that take one value."""
    canonical: dict[str, str] = {}
    counted: set[str] = set()
    for param in getattr(leaf, "params", ()):
        if getattr(param, "param_type_name", "") != "option" or param.is_flag:
            continue
        for name in (*param.opts, *param.secondary_opts):
            canonical[name] = param.opts[0]
        if not param.multiple:
            counted.add(param.opts[0])
    return canonical, counted


def refuse_repeated_options(command: Any, args: Sequence[str]) -> None:
    """Refuse an option that takes one value given more than once.

    click keeps the last value and drops the others without a word: ``--mount a.toml ...
    --mount b.toml`` georeferenced with ``b.toml``. Options that take several values
    (``--points``), flags and arguments are not counted.

    Parameters
    ----------
    command : click command
        The program's command tree (``typer.main.get_command``).
    args : sequence of str
        The command line, after `expand_multi_value_options`.

    Raises
    ------
    InputError
        Naming the option and every value it was given.
    """
    if "--help" in args:
        return  # help is shown whatever else the line holds
    found = _leaf(command, args)
    if found is None:
        return
    leaf, start = found
    canonical, counted = _value_options(leaf)
    given: dict[str, list[str]] = {}
    tokens = list(args[start:])
    i = 0
    while i < len(tokens):
        item = tokens[i]
        i += 1
        if item == "--":  # end of options
            break
        name, eq, value = item.partition("=")
        if name not in canonical:
            continue
        if not eq:
            value = tokens[i] if i < len(tokens) else ""
            i += 1  # the value is not an option, whatever it looks like
        if canonical[name] in counted:
            given.setdefault(canonical[name], []).append(value)
    for name, values in given.items():
        if len(values) > 1:
            shown = ", ".join(repr(v) for v in values)
            msg = (
                f"{name} given {len(values)} times ({shown}); it takes one value, and all but "
                "the last would be ignored: give it once"
            )
            raise InputError(msg)


def parse_rates(text: str) -> tuple[float, ...]:
    """Parse a comma-separated list of table rates (deg/s) such as ``2,4,6``.

    Raises
    ------
    InputError
        An empty list or item, a non-number, a non-finite, zero or negative rate.
    """
    items = [s.strip() for s in text.split(",")]
    if not text.strip():
        msg = "--rates-deg-s is empty; give comma-separated rates such as 2,4,6,10,14,18"
        raise InputError(msg)
    rates: list[float] = []
    for pos, item in enumerate(items, start=1):
        if not item:
            msg = f"--rates-deg-s {text!r}: item {pos} is empty; give rates such as 2,4,6"
            raise InputError(msg)
        try:
            rate = float(item)
        except ValueError:
            msg = f"--rates-deg-s {text!r}: item {pos} ({item!r}) is not a number"
            raise InputError(msg) from None
        if not math.isfinite(rate) or rate <= 0.0:
            msg = (
                f"--rates-deg-s {text!r}: item {pos} ({item!r}) must be a rate magnitude "
                "> 0 deg/s (each rate runs in both directions)"
            )
            raise InputError(msg)
        rates.append(rate)
    return tuple(rates)


def refuse_unused_gps_week(
    gps_week: int | None,
    *,
    trajectories: Sequence[Path] = (),
    points: Sequence[Path] = (),
    navigation: Sequence[Path] = (),
) -> None:
    """Refuse ``--gps-week`` when no input carries GPS seconds of week.

    A CSV trajectory or point table carries GPS time, a LAS/LAZ header says which time
    its points carry, a text export with a week column gives its own week, and an SBET
    or text export whose times lie beyond a week already holds GPS time: given with
    none that takes it, the week was accepted and not used.

    Parameters
    ----------
    gps_week : int or None
        The option's value (nothing to check when not given).
    trajectories : sequence of Path
        Trajectory files (CSV, SBET, text exports).
    points : sequence of Path
        Point files (LAS/LAZ take a week when their header says seconds of week).
    navigation : sequence of Path
        Navigation files (`kinsync.io.nav_csv.read_navigation`: an SBET takes a week).
    """
    if gps_week is None:
        return
    from kinsync._text import first_few  # noqa: PLC0415
    from kinsync.io.las import las_takes_gps_week  # noqa: PLC0415
    from kinsync.io.nav_csv import navigation_takes_gps_week  # noqa: PLC0415
    from kinsync.io.trajectory import (  # noqa: PLC0415
        trajectory_already_gps_time,
        trajectory_takes_gps_week,
    )

    named = [Path(p) for p in (*trajectories, *points, *navigation)]
    if not all(p.is_file() for p in named):
        return  # the reader names the missing input first
    if (
        any(trajectory_takes_gps_week(p) for p in trajectories)
        or any(las_takes_gps_week(p) for p in points)
        or any(navigation_takes_gps_week(p) for p in navigation)
    ):
        return
    names = first_few([str(p) for p in named])
    _refuse_week_on_csv(gps_week, trajectories)
    already = [str(p) for p in (*trajectories, *navigation) if trajectory_already_gps_time(p)]
    if already:
        msg = (
            f"--gps-week {gps_week}: the times of {first_few(already)} are already GPS time "
            "(seconds since 1980, beyond one week), not seconds of week, and no other input "
            f"carries seconds of week ({names}), so it would not be used: drop it"
        )
        raise InputError(msg)
    msg = (
        f"--gps-week {gps_week}: no input carries GPS seconds of week ({names}: a CSV "
        "carries GPS time, a LAS file's header says which, a text export with a week "
        "column gives its own), so it would not be used: drop it"
    )
    raise InputError(msg)


def _refuse_week_on_csv(gps_week: int, trajectories: Sequence[Path]) -> None:
    """Refuse --gps-week for a trajectory CSV whose times look like seconds of week.

    `kinsync trajectory export` without --gps-week writes one from an SBET; a CSV is read
    as GPS time, so the week does not apply: say what does.
    """
    from kinsync.io.gps_week import SECONDS_PER_WEEK, WEEK_SECONDS_MAX_S  # noqa: PLC0415
    from kinsync.io.trajectory import csv_first_time_s  # noqa: PLC0415

    for path in trajectories:
        if Path(path).suffix.lower() != ".csv":
            continue
        t_s = csv_first_time_s(Path(path))
        if t_s is None or not 0.0 <= t_s <= WEEK_SECONDS_MAX_S:
            continue
        shift_s = gps_week * SECONDS_PER_WEEK
        msg = (
            f"--gps-week {gps_week}: no input carries GPS seconds of week: a trajectory CSV "
            "is read as GPS time since 1980 and takes no GPS week, so it would not be used: "
            f"drop it; but the times of {path} (from {t_s:.10g} s) look like GPS seconds of "
            f"week: if they are, add {gps_week} x {SECONDS_PER_WEEK:.0f} = {shift_s:.0f} s "
            f"to its t_s, or write it again with kinsync trajectory export --gps-week {gps_week}"
        )
        raise InputError(msg)
