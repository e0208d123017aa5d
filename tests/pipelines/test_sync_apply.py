"""The Method B apply pipeline: a scan file time-tagged and put in the scanner frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.points import iter_table_chunks
from kinsync.io.profile_scan import (
    write_profile_scan,
)
from kinsync.mount import Mount
from kinsync.pipelines.sync_apply import apply_profile_clock
from kinsync.sync.scan import ProfileScan

MOUNT = Mount(profiler_azimuth_deg=30.0)
_RNG = np.random.default_rng(0)
SCAN = ProfileScan(  # 700 returns over 50 profiles, angles both sides of nadir
    profile=np.sort(_RNG.integers(0, 50, 700)),
    angle_rad=_RNG.uniform(-2.3, 2.3, 700),
    range_m=_RNG.uniform(0.5, 40.0, 700),
    intensity=_RNG.uniform(0.0, 1.0, 700),
)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_apply_adds_time_and_scanner_coordinates(tmp_path: Path, suffix: str) -> None:
    scan = SCAN
    src = tmp_path / f"scan{suffix}"
    write_profile_scan(scan, src, extra={"label": np.array([f"r{i}" for i in range(len(scan))])})
    out = tmp_path / f"out{suffix}"
    seen: list[int] = []
    n = apply_profile_clock(src, out, 100.0, 0.03, MOUNT, chunk_points=256, progress=seen.append)
    assert n == len(scan)
    assert seen == [256, 512, 700]
    (chunk,) = iter_table_chunks(out, 10_000, ("t_s", "x_m", "y_m", "z_m"))
    assert list(chunk)[:5] == ["profile", "angle_rad", "range_m", "intensity", "label"]
    assert chunk["label"].tolist() == [f"r{i}" for i in range(len(scan))]
    expected_t = 100.0 + (scan.profile + scan.angle_rad / (2 * np.pi)) * 0.03
    np.testing.assert_allclose(chunk["t_s"], expected_t, rtol=0, atol=1e-12)
    xyz = np.column_stack([chunk["x_m"], chunk["y_m"], chunk["z_m"]])
    np.testing.assert_allclose(xyz, MOUNT.profile_to_scanner(scan.angle_rad, scan.range_m))
    # Azimuth 30 deg: the profile plane is the scanner Y-Z plane turned about Z.
    normal = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0])
    np.testing.assert_allclose(xyz @ normal, 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(xyz, axis=1), scan.range_m)


def test_apply_bad_input(tmp_path: Path) -> None:
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,t_s\n0,0.1,2,5\n1,0.1,2,5\n")
    with pytest.raises(InputError, match=r"already has column\(s\) \['t_s'\]"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    with pytest.raises(InputError, match=r"\[profiler\]"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, Mount())
    with pytest.raises(InputError, match="period_s > 0"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.0, MOUNT)
    lines = "profile,angle_rad,range_m\n" + "".join(f"{p},0.1,2\n" for p in [0, 1, 2, 3, 1])
    dec = tmp_path / "dec.csv"
    dec.write_text(lines)
    with pytest.raises(InputError, match=r"row 4 \(line 6\).*1 after 3"):
        apply_profile_clock(dec, tmp_path / "o.csv", 0.0, 0.03, MOUNT, chunk_points=2)
    assert not (tmp_path / "o.csv").exists()
    assert not list(tmp_path.glob("*.part"))


@pytest.mark.parametrize("bad_range", ["-0.5", "1e307", "nan"])
def test_apply_refuses_a_negative_or_absurd_range(tmp_path: Path, bad_range: str) -> None:
    src = tmp_path / "scan.csv"
    src.write_text(f"profile,angle_rad,range_m\n0,0.1,2\n1,0.1,{bad_range}\n2,0.1,3\n")
    with pytest.raises(InputError, match=r"data row 1: .*a range is a finite distance"):
        apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    assert not (tmp_path / "o.csv").exists()


def test_apply_carries_extra_csv_columns_as_their_text(tmp_path: Path) -> None:
    src = tmp_path / "scan.csv"
    src.write_text("profile,angle_rad,range_m,code,big\n0,0.1,2,007,1180591620717411303424\n")
    apply_profile_clock(src, tmp_path / "o.csv", 0.0, 0.03, MOUNT)
    text = (tmp_path / "o.csv").read_text()
    assert ",007,1180591620717411303424," in text  # as written, and unquoted
    assert '"' not in text
