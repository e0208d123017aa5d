"""The demo's CRS section: zone, epoch and geoid figures checked against PROJ directly."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyproj

from kinsync.demo.crs import GEOID_N_M, OBSERVATION_EPOCH, OTHER_EPOCH, crs_section


def test_crs_section_figures_agree_with_proj(tmp_path: Path) -> None:
    summary: list[tuple[str, str, str]] = []
    section = crs_section(tmp_path, summary)
    doc = json.loads((tmp_path / "crs.json").read_text())
    assert doc["area"]["utm_epsg"] == "EPSG:32619"
    assert any("ppm" in w for w in doc["wrong_zone"]["warnings"])
    assert doc["right_zone"]["warnings"] == []
    csrs = doc["itrf2014_to_csrs_v8"]
    assert csrs["time_dependent"] is True
    assert csrs["epoch_year"] == OBSERVATION_EPOCH
    # The same shift from PROJ's own 4-D transformation of the drive's first point.
    llh = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    x, y, z = llh.transform(-71.21, 46.80, 10.0)
    t = pyproj.Transformer.from_crs("EPSG:7789", "EPSG:22819", always_xy=True)
    e0, n0, *_ = t.transform(x, y, z, OBSERVATION_EPOCH)
    e1, n1, *_ = t.transform(x, y, z, OTHER_EPOCH)
    direct = float(np.hypot(e0 - e1, n0 - n1))
    assert 0.05 < direct < 1.0
    assert abs(doc["epoch_shift_m"] - direct) < 0.005
    assert doc["geoid"]["geoid"] is not None
    assert doc["geoid_height_error_m"] < 1e-4
    assert "orthometric" in doc["geoid"]["heights"]
    assert ("need the grid" in doc["missing_grid"]) or (
        "PROJ has this geoid" in doc["missing_grid"]
    )
    assert summary
    assert summary[0][0] == "CRS and datums"
    assert f"{GEOID_N_M:g}" in " ".join(section.paragraphs)


def test_the_geoid_grid_is_named_as_the_report_folder_holds_it(tmp_path: Path) -> None:
    # The demo writes into a temporary folder renamed when complete: report.html and
    # crs.json named the grid by its path there, a folder that no longer existed.
    section = crs_section(tmp_path, [])
    text = (tmp_path / "crs.json").read_text()
    cells = " ".join(c for t in section.tables for row in t.rows for c in row)
    assert str(tmp_path) not in text
    assert str(tmp_path) not in cells
    assert json.loads(text)["geoid"]["geoid"] == "crs_demo_geoid.gtx"
    assert "crs_demo_geoid.gtx" in cells
