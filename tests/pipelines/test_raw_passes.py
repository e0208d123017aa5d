"""Method A raw input: raw passes read and georeferenced with the attitude log."""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from kinsync.errors import InputError, OutsideSpanError
from kinsync.frames import euler_rpy_to_matrix
from kinsync.georef.table import georeference_table_points
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.io.passes import read_passes
from kinsync.io.raw_passes import raw_pass_name, read_raw_attitude
from kinsync.latency.sphere import estimate_latency_sphere
from kinsync.mount import Mount
from kinsync.pipelines.raw_passes import read_raw_passes
from kinsync.sim.rotating_table import (
    RotatingTableSimulation,
    simulate_rotating_table,
    write_simulation,
)
from kinsync.sim.table_config import RotatingTableConfig
from kinsync.trajectory import Trajectory

BORESIGHT_DEG = (0.2, -0.1, 3.0)


@pytest.fixture(scope="module")
def sim() -> RotatingTableSimulation:
    cfg = RotatingTableConfig(
        rates_deg_s=(10.0,), passes=2, seed=3, boresight_rpy_deg=BORESIGHT_DEG
    )
    return simulate_rotating_table(cfg)


@pytest.fixture(scope="module")
def sim_folder(sim: RotatingTableSimulation, tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("raw_sim")
    write_simulation(sim, folder, raw=True)
    return folder


@pytest.fixture
def copy(sim_folder: Path, tmp_path: Path) -> Path:
    """A private copy of the simulated folder, free to break."""
    out = tmp_path / "copy"
    shutil.copytree(sim_folder, out)
    return out


def test_raw_passes_reproduce_the_georeferenced_ones(sim_folder: Path) -> None:
    geo = read_passes(sim_folder)
    raw = read_raw_passes(sim_folder)
    assert read_mount(sim_folder / "raw" / "mount.toml").latency_s == 0.0
    assert len(raw) == len(geo) == 4
    for g, r in zip(geo, raw, strict=True):
        assert r.rate_deg_s == g.rate_deg_s
        assert r.axis_ned == g.axis_ned
        assert Path(r.source).parent.name == "raw"
        assert Path(r.source).name == Path(g.source).name
        assert r.rate_checked_by is not None  # the attitude log turned with the table
        assert r.rate_checked_by.startswith("the attitude log ")
        assert g.rate_checked_by is None
        assert r.t_s is not None
        assert g.t_s is not None
        np.testing.assert_array_equal(r.t_s, g.t_s)
        np.testing.assert_allclose(r.points_ned_m, g.points_ned_m, rtol=0, atol=1e-9)


def test_raw_pass_name_rule(sim: RotatingTableSimulation, tmp_path: Path) -> None:
    assert raw_pass_name("pass_000.laz") == "pass_000.csv"
    assert raw_pass_name("pass_012.csv") == "pass_012.csv"
    assert raw_pass_name("sub/p.las") == "sub/p.csv"
    write_simulation(sim, tmp_path, file_format="las", raw=True)
    raw = read_raw_passes(tmp_path)
    assert [Path(p.source).name for p in raw] == [f"pass_00{i}.csv" for i in range(4)]
    for p, r in zip(sim.passes, raw, strict=True):
        np.testing.assert_allclose(r.points_ned_m, p.points_ned_m, rtol=0, atol=1e-9)


def test_latency_correction_removes_the_latency(
    sim: RotatingTableSimulation, sim_folder: Path
) -> None:
    """The sign of SPEC section 1: correcting by +tau_true leaves no latency to find."""
    tau = float(sim.truth["latency_s"])
    as_logged = estimate_latency_sphere(read_passes(sim_folder), radius_m=0.1)
    corrected = estimate_latency_sphere(read_raw_passes(sim_folder, latency_s=tau), radius_m=0.1)
    assert as_logged.latency_s == pytest.approx(tau, abs=4.0 * as_logged.latency_std_s)
    assert tau > 10.0 * as_logged.latency_std_s  # the test separates tau from 0
    assert abs(corrected.latency_s) < 4.0 * corrected.latency_std_s


def test_latency_defaults_to_the_mount(sim: RotatingTableSimulation, copy: Path) -> None:
    tau = float(sim.truth["latency_s"])
    write_mount(Mount(boresight_rpy_deg=BORESIGHT_DEG, latency_s=tau), copy / "raw" / "mount.toml")
    from_mount = read_raw_passes(copy)
    given = read_raw_passes(copy, latency_s=tau)
    zero = read_raw_passes(copy, latency_s=0.0)
    for a, b, c in zip(from_mount, given, zero, strict=True):
        np.testing.assert_array_equal(a.points_ned_m, b.points_ned_m)
        assert np.max(np.abs(a.points_ned_m - c.points_ned_m)) > 1e-4


def test_kernel_matches_the_formula() -> None:
    """x_n = R(yaw(t + tau)) (a + R_sb x_s) for a table turning about Down."""
    rate = math.radians(20.0)
    t_rec = np.linspace(0.0, 10.0, 1001)
    zeros = np.zeros_like(t_rec)
    att = Trajectory.from_euler(
        t_rec,
        zeros,
        zeros,
        rate * t_rec,
        pos_ned_m=np.zeros((t_rec.size, 3)),
        origin_lat_lon_h=(0.0, 0.0, 0.0),
    )
    mount = Mount(
        lever_arm_body_m=(0.1, -0.2, 0.05), boresight_rpy_deg=(1.0, -2.0, 30.0), latency_s=0.004
    )
    rng = np.random.default_rng(0)
    t = rng.uniform(1.0, 9.0, 50)
    xs = rng.normal(0.0, 2.0, (50, 3))
    out = georeference_table_points(t, xs, att, mount)
    R_sb = euler_rpy_to_matrix(*np.radians(mount.boresight_rpy_deg))
    for k in range(t.size):
        R = euler_rpy_to_matrix(0.0, 0.0, rate * (t[k] + 0.004))
        expected = R @ (np.array(mount.lever_arm_body_m) + R_sb @ xs[k])
        np.testing.assert_allclose(out[k], expected, rtol=0, atol=1e-12)
    with pytest.raises(OutsideSpanError, match="outside"):
        georeference_table_points([9.999], xs[:1], att, mount)  # needs the tag 10.003
    with pytest.raises(InputError, match="shape"):
        georeference_table_points(t, xs[:-1], att, mount)
    bad = xs.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match=r"point at index 3 \(0-based, of 50\), y: nan"):
        georeference_table_points(t, bad, att, mount)


def test_read_raw_attitude(sim: RotatingTableSimulation, sim_folder: Path) -> None:
    att = read_raw_attitude(sim_folder / "raw" / "attitude.csv")
    np.testing.assert_array_equal(att.t_s, sim.attitude.t_s)
    assert att.pos_ned_m is not None
    assert not np.any(att.pos_ned_m)
    R_a = att.interpolate(att.t_s).R_body_to_ned
    R_b = sim.attitude.interpolate(att.t_s).R_body_to_ned
    np.testing.assert_allclose(R_a, R_b, rtol=0, atol=1e-12)


def test_a_raw_attitude_log_may_hold_unwrapped_angles(tmp_path: Path) -> None:
    """A turning table's log may count its turns (`ANGLE_DEG`); `Trajectory.from_euler`
    refuses angles beyond a turn, so the reader must not go through it."""
    t = np.arange(0.0, 20.0, 0.1)
    yaw_deg = 40.0 * t  # two and a bit turns
    path = tmp_path / "attitude.csv"
    rows = "".join(f"{a:.17g},0.5,-1.0,{b:.17g}\n" for a, b in zip(t, yaw_deg, strict=True))
    path.write_text("t_s,roll_deg,pitch_deg,yaw_deg\n" + rows)
    att = read_raw_attitude(path)
    expected = euler_rpy_to_matrix(math.radians(0.5), math.radians(-1.0), np.radians(yaw_deg))
    np.testing.assert_allclose(att.interpolate(t).R_body_to_ned, expected, rtol=0, atol=1e-12)


def test_outside_the_attitude_span_names_pass_and_time(copy: Path) -> None:
    # -0.5 s: the first pass needs records 0.5 s before its start; the log starts 0.2 s before.
    with pytest.raises(InputError, match=r"pass_000\.csv: line \d+: point time t_s=") as exc:
        read_raw_passes(copy, latency_s=-0.5)
    assert "outside the attitude log" in str(exc.value)
    assert "passes.csv: line 2" in str(exc.value)


def _log_holes(raw: Path) -> list[tuple[float, float]]:
    """The attitude log's record intervals over 10 median intervals (between passes)."""
    t = read_raw_attitude(raw / "attitude.csv").t_s
    dt = np.diff(t)
    return [(float(t[k]), float(t[k + 1])) for k in np.flatnonzero(dt > 10 * np.median(dt))]


def test_a_latency_reading_the_hole_between_passes_is_an_error_naming_it(copy: Path) -> None:
    """+0.5 s: the end of the first pass reads the log's hole before the second pass.

    The table turns the other way in the next pass: interpolated across the hole, the
    attitude was a blend of two passes' rotations.
    """
    with pytest.raises(InputError, match=r"pass_000\.csv: line \d+: point time t_s=") as exc:
        read_raw_passes(copy, latency_s=0.5)
    msg = str(exc.value)
    assert "passes.csv: line 2" in msg
    assert "lies in a data gap of the attitude log" in msg
    hole = _log_holes(copy / "raw")[0]
    assert f"no record between the tags {hole[0]!r} .. {hole[1]!r} s" in msg
    assert "tau = 0.5 s" in msg
    assert "does not interpolate across gaps" in msg


def test_a_hole_in_the_attitude_log_during_a_pass_is_an_error(copy: Path) -> None:
    raw = copy / "raw"
    lines = (raw / "attitude.csv").read_text(encoding="utf-8").splitlines()
    t_pass = np.loadtxt(raw / raw_pass_name("pass_001.csv"), delimiter=",", skiprows=1)[:, 0]
    mid = float(np.median(t_pass))
    kept = [lines[0]] + [ln for ln in lines[1:] if abs(float(ln.split(",")[0]) - mid) > 0.25]
    assert len(lines) - len(kept) > 40
    (raw / "attitude.csv").write_text("\n".join(kept) + "\n", encoding="utf-8")
    n_in_hole = int(np.count_nonzero(np.abs(t_pass - mid) < 0.24))
    with pytest.raises(InputError, match=r"pass_001\.csv: line \d+: point time t_s=") as exc:
        read_raw_passes(copy)
    msg = str(exc.value)
    assert "passes.csv: line 3" in msg
    assert "data gap" in msg
    m = re.search(r"\((\d+) point\(s\) in all\)", msg)
    assert m is not None
    assert int(m.group(1)) >= n_in_hole > 0


def _rewrite(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, count), encoding="utf-8")


def _replace_line(path: Path, line_no: int, new: str) -> None:
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[line_no - 1] = new
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _repeat_attitude_record(raw: Path) -> None:
    lines = (raw / "attitude.csv").read_text(encoding="utf-8").splitlines()
    _replace_line(raw / "attitude.csv", 4, lines[2])


def _empty_pass(raw: Path) -> None:
    (raw / "pass_001.csv").write_text("t_s,x_m,y_m,z_m\n", encoding="utf-8")


BREAKERS: dict[str, Callable[[Path], None]] = {
    "no raw folder": shutil.rmtree,
    "no attitude": lambda raw: (raw / "attitude.csv").unlink(),
    "no mount": lambda raw: (raw / "mount.toml").unlink(),
    "bad mount": lambda raw: _rewrite(raw / "mount.toml", "latency_s = 0.0", "latency_s = 'soon'"),
    "no raw pass": lambda raw: (raw / "pass_001.csv").unlink(),
    "attitude column": lambda raw: _rewrite(raw / "attitude.csv", "pitch_deg", "pitch"),
    "pass column": lambda raw: _rewrite(raw / "pass_002.csv", "t_s,", "time,"),
    "non-numeric": lambda raw: _replace_line(raw / "pass_000.csv", 5, "1.0,abc,0.0,0.0"),
    "non-finite": lambda raw: _replace_line(raw / "pass_000.csv", 7, "1.0,nan,0.0,0.0"),
    "repeated tag": _repeat_attitude_record,
    "empty pass": _empty_pass,
    "no index": lambda raw: (raw.parent / "passes.csv").unlink(),
}


@pytest.mark.parametrize(
    ("case", "fragment"),
    [
        ("no folder", r"missing: pass folder not found"),
        ("no raw folder", r"raw: raw folder not found"),
        ("no attitude", r"attitude\.csv: attitude log not found"),
        ("no mount", r"mount\.toml: mount file not found"),
        ("bad mount", r"mount\.toml: \[mount\] latency_s"),
        ("no raw pass", r"passes\.csv: line 3: .*pass_001\.csv: raw pass file not found"),
        ("attitude column", r"attitude\.csv: missing column\(s\) \['pitch_deg'\]"),
        ("pass column", r"pass_002\.csv: missing column\(s\) \['t_s'\]"),
        ("non-numeric", r"pass_000\.csv: line 5, column 'x_m': 'abc' is not a number"),
        ("non-finite", r"pass_000\.csv: line 7, column 'x_m': nan is not a finite number"),
        ("repeated tag", r"attitude\.csv: line 4: repeated time"),
        ("empty pass", r"pass_001\.csv: the raw pass holds no points"),
        ("no index", r"passes\.csv: file not found"),
    ],
)
def test_bad_input_names_the_file(copy: Path, case: str, fragment: str) -> None:
    if case == "no folder":
        folder = copy / "missing"
    else:
        BREAKERS[case](copy / "raw")
        folder = copy
    with pytest.raises(InputError, match=fragment):
        read_raw_passes(folder)
