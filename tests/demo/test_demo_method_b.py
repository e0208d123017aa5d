"""Method B demo section: data set, figures and the clock against the truth."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kinsync.demo.method_b import method_b_section
from kinsync.report.html import render_report
from kinsync.sim.profiler import DRIVE_SCAN_FILES


def test_method_b_section(tmp_path: Path) -> None:
    summary: list[tuple[str, str, str]] = []
    section, doc = method_b_section(tmp_path, summary)
    assert "Method B" in section.title
    assert len(section.figures) == 2
    assert all(f.png.startswith(b"\x89PNG") for f in section.figures)
    assert (tmp_path / "method_b_1.png").read_bytes() == section.figures[0].png
    for name in DRIVE_SCAN_FILES:
        assert (tmp_path / "method-b" / name).is_file()
    saved = json.loads((tmp_path / "method_b.json").read_text())
    assert saved["truth"] == doc["truth"]
    for case in ("exact", "noisy"):
        est = saved[case]
        err = saved["errors"][case]
        assert abs(err["t0_s"]) < 4 * est["t0_std_s"]
        assert abs(err["period_s"]) < 4 * est["period_std_s"]
        assert est["pulse_offset"] == 1
    assert abs(saved["errors"]["exact"]["t0_s"]) < 2e-3
    assert abs(saved["errors"]["exact"]["period_s"]) < 5e-7
    wrong = saved["wrong_prior"]
    assert wrong["refused"] is True
    assert wrong["message"].startswith("--period-prior-s 0.0333 s: ")
    assert wrong["n_suggested"] == len(saved["exact"]["sightings"])
    assert abs(wrong["suggested_period_s"] / saved["truth"]["period_s"] - 1.0) < 1e-4
    (check,) = [c for c in section.checks if "wrong period prior" in c.quantity]
    assert check.passed, check
    assert "refused: " in check.detail
    # What the mount's errors would do to the clock: 1 cm along the track at 2 m/s is 5 ms.
    mount = section.paragraphs[-1]
    assert "1 cm of lever arm along the track moves t0 by -" in mount
    lever_ms = float(mount.split("moves t0 by ")[1].split(" ms")[0])
    assert abs(lever_ms) == pytest.approx(5.0, rel=0.1)
    (row,) = summary
    assert row[0].startswith("Method B")
    assert "pulse offset 1" in row[2]
    html = render_report("t", "i", [section])
    assert html.count("<img") == 2
    assert not list(tmp_path.glob("*.part"))
