"""The header of the LAS/LAZ files georef writes: version, software, date, identifier, CRS."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import laspy
import numpy as np
import pytest
from tests._las import las_points

from kinsync.errors import InputError
from kinsync.io.las_header import creation_date
from kinsync.io.provenance import software
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file
from kinsync.trajectory import Trajectory

WEEK = 2149
T0 = WEEK * 604_800.0 + 284_800.0  # GPS time
MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N = 200


def _trajectory(folder: Path) -> Path:
    s = np.arange(0.0, 11.0, 1.0)
    llh = np.column_stack([40.0 + s * 1e-5, np.full_like(s, -71.0), np.full_like(s, 50.0)])
    zeros = np.zeros_like(s)
    path = folder / "traj.csv"
    write_trajectory_csv(Trajectory.from_euler(T0 + s, zeros, zeros, zeros, lat_lon_h=llh), path)
    return path


def _las10(path: Path) -> Path:
    """A LAS 1.0 file, point format 1, GPS seconds of week; 20 points before the trajectory.

    The bytes of LAS 1.2 with the version minor 0 (the global encoding 0, the reserved
    field of LAS 1.0), as old software writes them.
    """
    rng = np.random.default_rng(3)
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.full(3, 1e-3)
    header.offsets = np.zeros(3)
    header.system_identifier = "ACME scanner 7"
    header.generating_software = "ACME export 1.0"
    header.creation_date = dt.date(2011, 3, 4)
    las = laspy.LasData(header)
    las.x, las.y, las.z = rng.uniform(-1, 1, N), rng.uniform(-9, 9, N), rng.uniform(-3, 3, N)
    las.gps_time = np.linspace(-2.0, 9.0, N) + T0 - WEEK * 604_800.0
    las.intensity = np.arange(N, dtype=np.uint16)
    las.write(path)
    raw = bytearray(path.read_bytes())
    raw[25] = 0  # version minor
    path.write_bytes(bytes(raw))
    return path


@pytest.mark.parametrize("suffix", [".laz", ".las", ".csv"])
def test_a_las_1_0_input_gives_las_1_2_outputs_and_says_so(tmp_path: Path, suffix: str) -> None:
    src = _las10(tmp_path / "old.las")
    assert laspy.read(src).header.version.minor == 0
    out = tmp_path / f"geo{suffix}"
    summary = georeference_file(
        src, _trajectory(tmp_path), MOUNT, out, gps_week=WEEK, outside="reject"
    )
    assert summary.points_rejected > 0
    assert summary.rejected_path is not None
    said = [w for w in summary.warnings if "LAS 1.0" in w]
    assert len(said) == 1
    assert said[0].startswith(f"{src}: it is LAS 1.0")
    assert "LAS/LAZ outputs are LAS 1.2, with the same point format (1)" in said[0]
    assert "damaged" not in " ".join(summary.warnings)
    stored = laspy.read(src)
    written = [laspy.read(summary.rejected_path)]
    if suffix != ".csv":
        written.append(laspy.read(out))
    for las in written:
        assert (las.header.version.major, las.header.version.minor) == (1, 2)
        assert las.header.point_format.id == 1
        assert las.header.global_encoding.value == 0
    rejected = written[0]
    n_rej = summary.points_rejected
    np.testing.assert_array_equal(rejected.gps_time, stored.gps_time[:n_rej])
    np.testing.assert_array_equal(rejected.X, stored.X[:n_rej])
    if suffix != ".csv":
        np.testing.assert_array_equal(written[1].gps_time, stored.gps_time[n_rej:])
        np.testing.assert_array_equal(written[1].intensity, stored.intensity[n_rej:])


def test_outputs_are_stamped_kinsync_today_and_keep_the_system_identifier(
    tmp_path: Path,
) -> None:
    src = _las10(tmp_path / "old.las")
    out = tmp_path / "geo.laz"
    summary = georeference_file(
        src, _trajectory(tmp_path), MOUNT, out, gps_week=WEEK, outside="reject"
    )
    assert summary.rejected_path is not None
    for path in (out, summary.rejected_path):
        header = laspy.read(path).header
        assert header.generating_software == software()
        assert header.creation_date == dt.date(2023, 11, 14)  # SOURCE_DATE_EPOCH
        assert header.system_identifier == "ACME scanner 7"


@pytest.mark.parametrize(("crs", "wkt1"), [("EPSG:4979", True), ("EPSG:8857", False)])
def test_the_output_crs_is_wkt1_or_wkt2_with_a_warning(
    tmp_path: Path, crs: str, wkt1: bool
) -> None:
    """Point format 6: WKT1 where it represents the CRS (Equal Earth it does not)."""
    rng = np.random.default_rng(5)
    t = np.linspace(0.5, 9.5, N) + T0
    cols = {"t_s": t, "x_m": rng.uniform(-1, 1, N), "y_m": rng.uniform(-9, 9, N)}
    cols["z_m"] = rng.uniform(-3, 3, N)
    src = tmp_path / "scan.las"
    las_points(cols).write(src)
    out = tmp_path / "geo.laz"
    summary = georeference_file(src, _trajectory(tmp_path), MOUNT, out, crs=crs)
    said = [w for w in summary.warnings if "WKT1" in w]
    record = next(
        v for v in laspy.read(out).header.vlrs if type(v).__name__ == "WktCoordinateSystemVlr"
    )
    text = str(record.string)
    if wkt1:
        assert not said
        assert text.startswith("COMPD_CS[")
    else:
        assert len(said) == 1
        assert said[0].startswith(f"{out}: its CRS 'WGS 84 / Equal Earth Greenwich'")
        assert text.startswith("PROJCRS[")


def test_the_creation_date_is_today_or_source_date_epochs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Today (UTC) without SOURCE_DATE_EPOCH; its date with it; a bad value is named."""
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    before = dt.datetime.now(dt.UTC).date()
    got = creation_date()
    assert got in {before, dt.datetime.now(dt.UTC).date()}
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    assert creation_date() == dt.date(1970, 1, 1)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1785000000")
    assert creation_date() == dt.date(2026, 7, 25)
    for bad in ("yesterday", "1.5e9", "99999999999999999999"):
        monkeypatch.setenv("SOURCE_DATE_EPOCH", bad)
        with pytest.raises(InputError, match=r"SOURCE_DATE_EPOCH=.*whole number of seconds"):
            creation_date()
