"""``kinsync demo``: run every landed capability on built-in data and write a report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from kinsync.cli._output import console
from kinsync.cli._progress import progress_display


def demo(
    out: Annotated[Path, typer.Option(help="Report folder to write.")] = Path("demo-output"),
) -> None:
    """Run the demo on built-in simulated data; writes OUT/report.html and prints a summary."""
    from kinsync.demo.run import run_demo  # noqa: PLC0415 - every other command starts faster

    with progress_display("demo") as progress:
        result = run_demo(out, progress=progress)
    table = Table(title="kinsync demo summary")
    for col in ("capability", "scenario", "result"):
        table.add_column(col)
    for row in result.summary:
        table.add_row(*row)
    console.print(table)
    console.print(f"report: {result.report_path}")
