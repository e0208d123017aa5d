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
calibrated on and spheres fitted to real vessel passes. A topic whose reference data
are not found is named in the report and on the terminal with the folders searched, and
the count of checks says it covers only the topics run. The report opens with what
produced it: kinsync's version, the date, the command, the folders and the seeds.
"""

from __future__ import annotations

import json
import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kinsync._text import first_few
from kinsync.demo import calibration as calibration_demo
from kinsync.demo import georef as georef_demo
from kinsync.demo import method_a as method_a_demo
from kinsync.demo import method_b as method_b_demo
from kinsync.demo import validation as validation_demo
from kinsync.demo.budget import budget_section
from kinsync.demo.calibration import calibration_section
from kinsync.demo.clock import clock_section
from kinsync.demo.crs import crs_section
from kinsync.demo.end_to_end import end_to_end_section
from kinsync.demo.end_to_end_survey import EndToEndConfig
from kinsync.demo.georef import georef_section
from kinsync.demo.ins import InsDemoSetup, ins_section
from kinsync.demo.manifest import MANIFEST, check_manifest, write_manifest
from kinsync.demo.method_a import (
    cidco_candidates,
    cidco_section,
    find_cidco_folder,
    method_a_section,
)
from kinsync.demo.method_b import method_b_section
from kinsync.demo.navego import (
    NAVEGO_TITLE,
    find_navego_folder,
    navego_candidates,
    navego_section,
)
from kinsync.demo.validation import validation_section
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_folder, atomic_write_bytes, atomic_write_text
from kinsync.io.provenance import run_time_utc, software_version
from kinsync.progress import Progress, Stages
from kinsync.report.html import Section, Skipped, render_report, summary_line
from kinsync.sim.clock import ClockSimConfig
from kinsync.sim.profiler import DriveScanConfig

__all__ = ["MANIFEST", "DemoResult", "check_demo_folder", "run_demo"]

CIDCO_TITLE = (
    "Sphere fitting on real returns (CIDCO, Port de Québec), and the CIDCO boresight "
    "calibration in the mount self-calibration"
)
"""The CIDCO parts, as the report names them when they are not run."""

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
    passed, total : int
        Checks passed, and checks in all, over the topics run.
    failed : tuple of str
        Each failed check, ``topic: what was measured``.
    skipped : tuple of Skipped
        Topics not run (their reference data not found), with the folders searched.
    count_line : str
        The report's count, e.g. ``35 of 38 checks pass``, saying when it covers only
        the topics run.
    """

    out_dir: Path
    report_path: Path
    summary: tuple[tuple[str, str, str], ...]
    passed: int = 0
    total: int = 0
    failed: tuple[str, ...] = ()
    skipped: tuple[Skipped, ...] = ()
    count_line: str = ""

    def as_document(self) -> dict[str, Any]:
        """The terminal summary as a JSON-ready mapping (``kinsync demo --json``)."""
        return {
            "report": str(self.report_path),
            "out_dir": str(self.out_dir),
            "checks_passed": self.passed,
            "checks_total": self.total,
            "summary": self.count_line,
            "failed_checks": list(self.failed),
            "skipped_topics": [{"topic": k.title, "reason": k.reason} for k in self.skipped],
            "rows": [{"capability": c, "scenario": sc, "result": r} for c, sc, r in self.summary],
        }


@dataclass(frozen=True)
class _Outcome:
    """What `_run_sections` made: the summary rows, the topics run and those not run."""

    summary: list[tuple[str, str, str]]
    sections: list[Section]
    skipped: list[Skipped]


INTRO = (
    "kinsync's synchronisation, calibration, georeferencing and validation methods run on "
    "simulated surveys whose truth is known (and on public real data sets where they are "
    "present beside the checkout). Each topic is judged against a tolerance fixed before "
    "the run, with its reason: a survey commonly specified to 3 cm leaves about 10 mm to "
    "any one error source. The verdicts come first, the evidence after them."
)
"""The paragraph under the report's heading."""


def _conclusion(sections: Sequence[Section], skipped: Sequence[Skipped] = ()) -> tuple[str, ...]:
    """What the verdicts mean for a survey, in words: no more than the checks measured."""
    failed = [s.title for s in sections if any(not c.passed for c in s.checks)]
    judged = [s for s in sections if s.checks]
    if failed:
        verdict = (
            "Topics with a failed check: "
            + "; ".join(failed)
            + ". Read their evidence before relying on that part of the chain."
        )
    else:
        verdict = (
            f"Every check of the {len(judged)} topics run meets its tolerance. A pass means "
            "what that check measured, as the summary lists it, and no more"
            + (
                "; what the checks do not cover is listed above."
                if any(s.caveats for s in sections)
                else "."
            )
        )
    if skipped:
        verdict += (
            f" {len(skipped)} topic{'s' if len(skipped) > 1 else ''} could not run "
            "(reference data not found) and are judged neither way: "
            + "; ".join(k.title for k in skipped)
            + "."
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


def run_demo(
    out_dir: Path, progress: Progress | None = None, command: str | None = None
) -> DemoResult:
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
    command : str, optional
        The command line that runs the demo, shown in the report (default
        ``kinsync demo --out OUT_DIR``).

    Returns
    -------
    DemoResult

    Raises
    ------
    InputError
        ``out_dir`` is a file or holds other files (before any work).
    """
    final_dir = Path(out_dir)
    command = command or shlex.join(["kinsync", "demo", "--out", str(final_dir)])
    with atomic_folder(final_dir, check_demo_folder, "choose another --out", option="--out") as tmp:
        outcome = _run_sections(tmp, progress, final_dir, command)
        write_manifest(tmp)
    checks = [(s.title, c) for s in outcome.sections for c in s.checks]
    return DemoResult(
        out_dir=final_dir,
        report_path=final_dir / "report.html",
        summary=tuple(outcome.summary),
        passed=sum(c.passed for _, c in checks),
        total=len(checks),
        failed=tuple(f"{t}: {c.quantity}" for t, c in checks if not c.passed),
        skipped=tuple(outcome.skipped),
        count_line=summary_line(outcome.sections, outcome.skipped),
    )


def _not_found(title: str, data: str, searched: list[Path]) -> Skipped:
    """A topic not run because its reference data are in none of ``searched``."""
    where = " and ".join(str(p) for p in searched)
    return Skipped(
        title,
        f"not run: {data} not found (searched {where}); put the data set in ../shared beside "
        "the working folder or the checkout to run it",
    )


def _seeds() -> str:
    """The seeds of every simulation the demo draws, as the report states them."""
    vehicle, vessel = (calibration_demo.SEED[k] for k in ("vehicle", "vessel"))
    parts = [
        f"Method A table {method_a_demo.TABLE_SEED}",
        f"clock logs {ClockSimConfig().seed}",
        f"georeferencing scan {georef_demo.SCAN_SEED} (velocity check {georef_demo.VELOCITY_SEED})",
        f"MEMS drive {InsDemoSetup().seed}",
        f"Method B drive {DriveScanConfig().seed} (trajectory noise {method_b_demo.NOISE_SEED})",
        f"end-to-end survey {EndToEndConfig().seed}",
        f"validation scenes {validation_demo.SCENE_SEED}",
        f"patch tests vehicle {vehicle}, vessel {vessel} (later survey {vessel + 100})",
    ]
    return "; ".join(parts)


def _about(
    final_dir: Path, command: str, navego: Path | None, cidco: Path | None
) -> list[tuple[str, str]]:
    """What produced the report: version, date, command, folders, seeds."""

    def data(found: Path | None, searched: list[Path]) -> str:
        if found is not None:
            return f"{found} (used)"
        return "not found; searched " + " and ".join(str(p) for p in searched)

    return [
        ("kinsync version", software_version()),
        ("date (UTC)", run_time_utc().strftime("%Y-%m-%d %H:%M:%S")),
        ("command", command),
        ("output folder", str(Path(final_dir).absolute())),
        ("NaveGo synthetic set", data(navego, navego_candidates())),
        ("CIDCO Port de Québec passes", data(cidco, cidco_candidates())),
        ("simulation seeds", _seeds()),
    ]


def _run_sections(
    out_dir: Path, progress: Progress | None, final_dir: Path | None = None, command: str = ""
) -> _Outcome:
    """Run every part into ``out_dir``, the report last; what it made."""
    summary: list[tuple[str, str, str]] = []
    sections: list[Section] = []
    skipped: list[Skipped] = []
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
    else:
        skipped.append(
            _not_found(
                NAVEGO_TITLE, "the NaveGo synthetic set (imu_gnss_spec.json)", navego_candidates()
            )
        )
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
        "mount self-calibration from survey lines (simulated patch tests"
        + (", CIDCO)" if cidco is not None else ")"),
    )
    sections.append(calibration_section(out_dir, summary, cidco, say)[0])
    if cidco is not None:
        stages.start("CIDCO spheres", "sphere fits on the CIDCO real passes")
        sections.append(cidco_section(cidco, out_dir, summary))
    else:
        skipped.append(
            _not_found(
                CIDCO_TITLE,
                "the CIDCO Port de Québec sphere passes (sphere1/)",
                cidco_candidates(),
            )
        )

    stages.start("report")
    report_path = out_dir / "report.html"
    about = _about(final_dir or out_dir, command, navego, cidco)
    html_text = render_report(
        REPORT_TITLE,
        INTRO,
        sections,
        _conclusion(sections, skipped),
        skipped=skipped,
        about=about,
    )
    atomic_write_text(report_path, html_text)
    stages.finish()
    return _Outcome(summary=summary, sections=sections, skipped=skipped)
