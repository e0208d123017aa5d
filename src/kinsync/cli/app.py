"""Root typer application: command groups and ``--version``."""

from __future__ import annotations

from typing import Annotated

import typer

from kinsync.cli import (
    budget,
    calibrate,
    clock,
    demo,
    georef,
    ins,
    inspect,
    latency,
    simulate,
    simulate_validation,
    sync,
    validate,
)
from kinsync.cli._guard import guard_commands
from kinsync.cli._help import install_flag_display

install_flag_display()

app = typer.Typer(
    name="kinsync",
    help="Time synchronisation and latency calibration of kinematic laser scanning systems.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(budget.app, name="budget")
app.add_typer(latency.app, name="latency")
app.add_typer(inspect.mount_app, name="mount")
app.add_typer(inspect.trajectory_app, name="trajectory")
app.command(name="demo")(demo.demo)
simulate.app.command(name="validation")(simulate_validation.validation)
app.add_typer(simulate.app, name="simulate")
app.add_typer(clock.app, name="clock")
app.command(name="georef")(georef.georef)
app.add_typer(ins.app, name="ins")
app.add_typer(validate.app, name="validate")
app.add_typer(sync.app, name="sync")
app.add_typer(calibrate.app, name="calibrate")


def _version(value: bool) -> None:
    if value:
        from kinsync.io.provenance import software  # noqa: PLC0415 - a checkout's commit

        typer.echo(software())
        raise typer.Exit(0)


@app.callback()
def root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """Time synchronisation and latency calibration of kinematic laser scanning systems."""


guard_commands(app)
