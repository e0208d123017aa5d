"""``kinsync demo``: run every landed capability on built-in data and write a report."""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from kinsync.cli._output import console, print_json
from kinsync.cli._progress import progress_display


def demo(
    out: Annotated[Path, typer.Option(help="Report folder to write.")] = Path("demo-output"),
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the summary as one JSON object.")
    ] = False,
) -> None:
    """Run the demo on built-in simulated data; writes OUT/report.html and prints a summary.

    The summary ends with the count of checks that pass, the failed checks by name and the
    topics not run (reference data not found); the exit status is 0 whether checks pass or
    fail (the report is the verdict), 2 on bad input.
    """
    from kinsync.demo.run import run_demo  # noqa: PLC0415 - every other command starts faster

    words = ["kinsync", "demo", "--out", str(out), *(["--json"] if as_json else [])]
    with progress_display("demo") as progress:
        result = run_demo(out, progress=progress, command=shlex.join(words))
    if as_json:
        print_json(result.as_document())
        return
    table = Table(title="kinsync demo summary")
    for col in ("capability", "scenario", "result"):
        table.add_column(col)
    for row in result.summary:
        table.add_row(*row)
    console.print(table)
    console.print(f"summary: {result.count_line}")
    for name in result.failed:
        console.print(f"  FAIL {name}")
    for topic in result.skipped:
        console.print(f"  {topic.title}: {topic.reason}")  # the reason says "not run"
    console.print(f"report: {result.report_path}")
