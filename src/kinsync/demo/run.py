"""The demo: every capability run on built-in data, written as one report folder.

The report leads with a verdict per topic (what was measured, the value with its σ, the
tolerance fixed in `kinsync.demo.tolerances` and pass or fail), then the evidence, and
ends with a conclusion. Sections: the latency, serial and period error budgets; Method A
on a simulated rotating-table campaign; the PPS + ZDA clock model on simulated logs with
faults; direct georeferencing of a simulated million-point scan against analytic truth;
INS/GNSS on a simulated MEMS drive (and on the NaveGo set when ``../shared`` is
present); Method B on a simulated profile-scanner drive; the end-to-end chain on one
simulated survey (INS/GNSS -> Method B -> georeferencing -> validation) with the correct
calibration, a wrong latency and a wrong clock; validation of control points and wall
flatness; mount self-calibration (boresight, lever arm, latency) on simulated vehicle
and vessel patch tests; and, when the CIDCO data sit in ``../shared``, the boresight
calibrated on and spheres fitted to real vessel passes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from kinsync._text import first_few
from kinsync.demo.budget import budget_section
from kinsync.demo.calibration import calibration_section
from kinsync.demo.clock import clock_section
from kinsync.demo.crs import crs_section
from kinsync.demo.end_to_end import end_to_end_section
from kinsync.demo.georef import georef_section
from kinsync.demo.ins import ins_section
from kinsync.demo.manifest import MANIFEST, check_manifest, write_manifest
from kinsync.demo.method_a import cidco_section, find_cidco_folder, method_a_section
from kinsync.demo.method_b import method_b_section
from kinsync.demo.navego import find_navego_folder, navego_section
from kinsync.demo.validation import validation_section
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_folder, atomic_write_bytes, atomic_write_text
from kinsync.progress import Progress, Stages
from kinsync.report.html import Section, render_report

__all__ = ["MANIFEST", "DemoResult", "check_demo_folder", "run_demo"]

REPORT_TITLE = "kinsync demo report"
"""The report's heading; a ``report.html`` holding it marks a folder the demo wrote."""


@dataclass(frozen=True)
class DemoResult:
    """What the demo wrote and the headline figures it prints.

    Attributes
    ----------
    out_dir : Path
        Report folder.
    report_path : Path
        The HTML report.
    summary : tuple of (str, str, str)
        Rows of (capability, scenario, result) for the terminal summary.
    """

    out_dir: Path
    report_path: Path
    summary: tuple[tuple[str, str, str], ...]


INTRO = (
    "kinsync's synchronisation, calibration, georeferencing and validation methods run on "
    "simulated surveys whose truth is known (and on public real data sets where they are "
    "present beside the checkout). Each topic is judged against a tolerance fixed before "
    "the run, with its reason: a survey commonly specified to 3 cm leaves about 10 mm to "
    "any one error source. The verdicts come first, the evidence after them."
)
"""The paragraph under the report's heading."""


def _conclusion(sections: list[Section]) -> tuple[str, ...]:
    """What the verdicts mean for a survey, in words."""
    failed = [s.title for s in sections if any(not c.passed for c in s.checks)]
    if failed:
        verdict = (
            "Topics with a failed check: "
            + "; ".join(failed)
            + ". Read their evidence before relying on that part of the chain."
        )
    else:
        verdict = (
            "Every topic meets its tolerance: on these data the latency, the clock, the "
            "georeferencing and the trajectory each stay within their share of a 3 cm survey, "
            "and validation flags each injected error while leaving the correct calibration "
            "alone."
        )
    return (
        verdict,
        (
            "The simulated topics show what the methods achieve when the model holds; on a "
            "real system, run the validation (control points, wall flatness) on every "
            "survey: it is the check that does not need the truth."
        ),
    )


_STAGE_WEIGHTS = {
    "error budgets": 2.0,
    "Method A": 22.0,
    "clock": 1.0,
    "georeferencing": 4.0,
    "coordinate systems": 1.0,
    "INS/GNSS": 4.0,
    "NaveGo": 7.0,
    "Method B": 1.0,
    "end-to-end": 4.0,
    "validation": 3.0,
    "mount self-calibration": 50.0,
    "CIDCO spheres": 1.0,
    "report": 1.0,
}
"""Each part's share of the demo's time (measured on 2 cores with ../shared), for the bar."""


def check_demo_folder(out_dir: Path) -> None:
    """Refuse an existing ``out_dir`` that holds anything but an earlier demo report.

    Parameters
    ----------
    out_dir : Path
        The demo's output folder (existing or not).

    Raises
    ------
    InputError
        ``out_dir`` is a folder that is neither empty nor an earlier demo output (its
        ``report.html`` with the demo's heading and its ``budget.json``), or an earlier
        demo output holding anything its `MANIFEST` does not list
        (`kinsync.demo.manifest.check_manifest`).
    """
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        return
    entries = sorted(p.name for p in out_dir.iterdir())
    if not entries:
        return
    report = out_dir / "report.html"
    try:
        ours = report.is_file() and REPORT_TITLE in report.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        ours = False
    if ours and (out_dir / "budget.json").is_file():
        check_manifest(out_dir)
        return
    msg = (
        f"--out {out_dir}: the folder holds other files ({first_few(entries)}); give a new or "
        "empty folder (or one holding an earlier demo report, which is replaced)"
    )
    raise InputError(msg)


def run_demo(out_dir: Path, progress: Progress | None = None) -> DemoResult:
    """Run every capability on built-in data and write the report folder.

    Parameters
    ----------
    out_dir : Path
        Folder to write (created if missing): ``report.html``, ``budget.json`` and the
        figures as PNG files. It must be missing, empty or hold an earlier demo report
        (`check_demo_folder`); the report is written into a hidden folder beside it and
        renamed into place when complete, replacing the earlier one as a whole (an
        interrupted demo leaves the folder as it was).
    progress : Progress, optional
        Told the share of the demo done and what runs now, as each part starts.

    Returns
    -------
    DemoResult

    Raises
    ------
    InputError
        ``out_dir`` is a file or holds other files (before any work).
    """
    final_dir = Path(out_dir)
    with atomic_folder(final_dir, check_demo_folder, "choose another --out", option="--out") as tmp:
        summary = _run_sections(tmp, progress)
        write_manifest(tmp)
    return DemoResult(
        out_dir=final_dir, report_path=final_dir / "report.html", summary=tuple(summary)
    )


def _run_sections(out_dir: Path, progress: Progress | None) -> list[tuple[str, str, str]]:
    """Run every part into ``out_dir``, the report last; return the summary rows."""
    summary: list[tuple[str, str, str]] = []
    sections: list[Section] = []
    stages = Stages(progress, _STAGE_WEIGHTS)
    say = stages.say

    stages.start("error budgets")
    budget, budget_doc = budget_section(summary)
    sections.append(budget)
    atomic_write_text(out_dir / "budget.json", json.dumps(budget_doc, indent=2) + "\n")
    for i, fig in enumerate(budget.figures):
        atomic_write_bytes(out_dir / f"budget_{i + 1}.png", fig.png)

    stages.start("Method A")
    sections.append(method_a_section(out_dir, summary, say))
    stages.start("clock", "clock model from simulated PPS + ZDA logs")
    sections.append(clock_section(out_dir, summary))
    stages.start("georeferencing", "georeferencing a simulated scan")
    sections.append(georef_section(out_dir, summary))
    stages.start("coordinate systems", "coordinate systems, datums, epochs and geoid heights")
    sections.append(crs_section(out_dir, summary))
    stages.start("INS/GNSS")
    sections.append(ins_section(out_dir, summary, progress=say)[0])
    navego = find_navego_folder()
    if navego is not None:
        stages.start("NaveGo")
        sections.append(navego_section(navego, out_dir, summary, say)[0])
    stages.start("Method B", "Method B: profile scanner synchronised in object space")
    method_b, _ = method_b_section(out_dir, summary)
    sections.append(method_b)
    stages.start("end-to-end")
    sections.append(end_to_end_section(out_dir, summary, say)[0])
    stages.start(
        "validation", "validation: control points and wall flatness, right and wrong calibration"
    )
    sections.append(validation_section(out_dir, summary))
    cidco = find_cidco_folder()
    stages.start(
        "mount self-calibration",
        "mount self-calibration from survey lines (simulated patch tests, CIDCO)",
    )
    sections.append(calibration_section(out_dir, summary, cidco)[0])
    if cidco is not None:
        stages.start("CIDCO spheres", "sphere fits on the CIDCO real passes")
        sections.append(cidco_section(cidco, summary))

    stages.start("report")
    report_path = out_dir / "report.html"
    html_text = render_report(REPORT_TITLE, INTRO, sections, _conclusion(sections))
    atomic_write_text(report_path, html_text)
    stages.finish()
    return summary
