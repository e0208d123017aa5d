"""Method B files: scan tables, sync points, pulses, clock documents, the apply pipeline."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinsync.clock.model import ClockModel
from kinsync.errors import InputError, KinsyncWarning
from kinsync.frames import geodetic_to_ecef
from kinsync.io.clock_model import write_clock_model
from kinsync.io.profile_scan import (
    read_clock_document,
    read_clock_file,
    read_profile_scan,
    read_pulses,
    read_sync_points,
    write_profile_scan,
    write_pulses,
    write_sync_points,
)
from kinsync.mount import Mount
from kinsync.sync.clock_mount import ClockMount
from kinsync.sync.scan import ProfileScan, SyncPoints

MOUNT = Mount(profiler_azimuth_deg=30.0)


def _scan(n: int = 500, seed: int = 0) -> ProfileScan:
    rng = np.random.default_rng(seed)
    return ProfileScan(
        profile=np.sort(rng.integers(0, 50, n)),
        angle_rad=rng.uniform(-2.3, 2.3, n),
        range_m=rng.uniform(0.5, 40.0, n),
        intensity=rng.uniform(0.0, 1.0, n),
    )


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_scan_round_trip_is_exact(tmp_path: Path, suffix: str) -> None:
    scan = _scan()
    path = tmp_path / f"scan{suffix}"
    write_profile_scan(scan, path, extra={"label": np.arange(len(scan))})
    back = read_profile_scan(path)
    np.testing.assert_array_equal(back.profile, scan.profile)
    for name in ("angle_rad", "range_m", "intensity"):
        np.testing.assert_array_equal(getattr(back, name), getattr(scan, name))
    assert back.n_profiles == int(scan.profile[-1]) + 1
    assert back.source == str(path)


@given(
    rows=st.lists(
        st.tuples(
            st.integers(0, 3),
            st.floats(-math.pi, math.pi, allow_nan=False),
            st.floats(0.0, 1e3, allow_nan=False),
            st.floats(-1e3, 1e3, allow_nan=False),
        ),
        min_size=1,
        max_size=30,
    )
)
@settings(max_examples=40, deadline=None)
def test_scan_csv_round_trip_property(
    rows: list[tuple[int, float, float, float]], tmp_path_factory: pytest.TempPathFactory
) -> None:
    steps = np.array([r[0] for r in rows])
    scan = ProfileScan(
        profile=np.cumsum(steps),
        angle_rad=np.array([r[1] for r in rows]),
        range_m=np.array([r[2] for r in rows]),
        intensity=np.array([r[3] for r in rows]),
    )
    path = tmp_path_factory.mktemp("p") / "s.csv"
    write_profile_scan(scan, path)
    with warnings.catch_warnings():  # a range of 0 is read, with a warning (tested below)
        warnings.simplefilter("ignore", KinsyncWarning)
        back = read_profile_scan(path)
    np.testing.assert_array_equal(back.profile, scan.profile)
    np.testing.assert_array_equal(back.angle_rad, scan.angle_rad)
    np.testing.assert_array_equal(back.range_m, scan.range_m)
    np.testing.assert_array_equal(back.intensity, scan.intensity)


def _write_text(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


SCAN_HEAD = "profile,angle_rad,range_m,intensity\n"


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("profile,angle_rad,range_m\n0,0.1,2\n", ["missing column", "intensity"]),
        (f"{SCAN_HEAD}0,0.1,2,0.5\n1,x,2,0.5\n", ["line 3, column 'angle_rad'"]),
        (
            "profile,angle_rad,range_m,intensity\n0,0.1,2,0.5\n3,0.1,2,0.5\n2,0.1,2,0.5\n",
            ["line 4, column 'profile'", "must not decrease", "2 after 3"],
        ),
        (f"{SCAN_HEAD}0.5,0.1,2,0.5\n", ["line 2, column 'profile'", "whole"]),
        (f"{SCAN_HEAD}-1,0.1,2,0.5\n", ["line 2, column 'profile'", "to 1e+12"]),
        ("profile,angle_rad,range_m,intensity\n0,0.1,-2,0.5\n", ["'range_m'", "negative"]),
        ("profile,angle_rad,range_m,intensity\n0,inf,2,0.5\n", ["angle_rad", "finite"]),
        (  # 2,800 turns were plausible; a mirror angle is within one turn
            f"{SCAN_HEAD}0,0.1,2,0.5\n1,45.0,2,0.5\n",
            ["line 3, column 'angle_rad'", "a mirror angle (one turn)"],
        ),
        ("profile,angle_rad,range_m,intensity\n", ["no data rows"]),
        ("", ["empty file"]),
    ],
)
def test_bad_scans_name_the_problem(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = _write_text(tmp_path, "scan.csv", text)
    with pytest.raises(InputError) as err:
        read_profile_scan(path)
    for frag in fragments:
        assert frag in str(err.value)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("value", ["1e308", "1e13", "nan", "-inf"])
def test_absurd_profile_numbers_are_refused_without_a_warning(tmp_path: Path, value: str) -> None:
    """A column of 1e308 was cast to int64 (a RuntimeWarning) and went on at exit 0."""
    text = f"profile,angle_rad,range_m,intensity\n0,0.1,2,0.5\n{value},0.1,2,0.5\n"
    path = _write_text(tmp_path, "scan.csv", text)
    want = r"scan\.csv: line 3, column 'profile': .* is not a profile number"
    with pytest.raises(InputError, match=want) as err:
        read_profile_scan(path)
    assert "np.float64" not in str(err.value)


def test_scan_missing_file_and_bad_suffix(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        read_profile_scan(tmp_path / "nope.csv")
    with pytest.raises(InputError, match="unknown table type"):
        read_profile_scan(_write_text(tmp_path, "scan.txt", "profile\n"))


def test_scan_container_checks_lengths() -> None:
    with pytest.raises(InputError, match=r"shape \(1,\), expected \(2,\)"):
        ProfileScan(
            profile=np.array([0, 1]),
            angle_rad=np.array([0.0]),
            range_m=np.ones(2),
            intensity=np.ones(2),
        )
    with pytest.raises(InputError, match="no returns"):
        ProfileScan(
            profile=np.array([], dtype=np.int64),
            angle_rad=np.array([]),
            range_m=np.array([]),
            intensity=np.array([]),
        )


def test_sync_points_round_trip_and_ecef(tmp_path: Path) -> None:
    pts = SyncPoints(
        names=("S1", "S 2"),
        lat_lon_h=np.array([[46.8, -71.2, 10.0], [46.8001, -71.2002, 11.5]]),
    )
    path = tmp_path / "pts.csv"
    write_sync_points(pts, path)
    back = read_sync_points(path)
    assert back.names == pts.names
    assert back.lines == (2, 3)  # messages name a point by its line
    assert back.label(1) == "'S 2' (line 3)"
    assert pts.label(1) == "'S 2'"
    np.testing.assert_array_equal(back.lat_lon_h, pts.lat_lon_h)
    np.testing.assert_allclose(
        back.pos_ecef_m(), geodetic_to_ecef([46.8, 46.8001], [-71.2, -71.2002], [10.0, 11.5])
    )


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("name,lat_deg,lon_deg\nA,1,2\n", ["missing column", "h_m"]),
        ("name,lat_deg,lon_deg,h_m\nA,1,2,3\nA,1,2,3\n", ["line 3", "already used on line 2"]),
        ("name,lat_deg,lon_deg,h_m\n,1,2,3\n", ["line 2", "empty name"]),
        ("name,lat_deg,lon_deg,h_m\nA,91,2,3\n", ["line 2", "latitude"]),
        ("name,lat_deg,lon_deg,h_m\nA,x,2,3\n", ["line 2", "lat_deg", "'x'"]),
        ("name,lat_deg,lon_deg,h_m\nA,1,nan,3\n", ["lon_deg", "finite"]),
        ("name,lat_deg,lon_deg,h_m\nA,1,2\n", ["line 2 has 3 fields"]),
        ("name,lat_deg,lon_deg,h_m\n", ["no data rows"]),
        ("", ["empty file"]),
    ],
)
def test_bad_sync_points(tmp_path: Path, text: str, fragments: list[str]) -> None:
    path = _write_text(tmp_path, "pts.csv", text)
    with pytest.raises(InputError) as err:
        read_sync_points(path)
    for frag in fragments:
        assert frag in str(err.value)
    with pytest.raises(InputError, match="not found"):
        read_sync_points(tmp_path / "missing.csv")


def test_sync_points_container_checks() -> None:
    with pytest.raises(InputError, match="more than once"):
        SyncPoints(names=("A", "A"), lat_lon_h=np.zeros((2, 3)))
    with pytest.raises(InputError, match="one"):
        SyncPoints(names=("A",), lat_lon_h=np.zeros((2, 3)))


def test_pulses_round_trip_and_bad_input(tmp_path: Path) -> None:
    t = 1.4e9 + 0.0305 * np.arange(100) + 1e-7
    path = tmp_path / "pulses.csv"
    write_pulses(t, path)
    np.testing.assert_array_equal(read_pulses(path), t)
    with pytest.raises(InputError, match=r"line 4: pulse time .* strictly increasing"):
        read_pulses(_write_text(tmp_path, "p1.csv", "t_s\n1.0\n2.0\n1.5\n"))
    with pytest.raises(InputError, match="1 pulse"):
        read_pulses(_write_text(tmp_path, "p2.csv", "t_s\n1.0\n"))
    with pytest.raises(InputError, match="'t_s'"):
        read_pulses(_write_text(tmp_path, "p3.csv", "t_s\n1.0\nabc\n"))
    with pytest.raises(InputError, match="missing column"):
        read_pulses(_write_text(tmp_path, "p4.csv", "time\n1.0\n2.0\n"))


def test_clock_document(tmp_path: Path) -> None:
    good = _write_text(tmp_path, "c.json", json.dumps({"t0_s": 12.5, "period_s": 0.03, "x": 1}))
    assert read_clock_document(good) == (12.5, 0.03)
    cases = {
        "{": "not valid JSON",
        "[1, 2]": "JSON object",
        json.dumps({"t0_s": 1.0}): "not a profile clock: no period_s",
        json.dumps({"t0_s": 1.0, "period_s": None}): "'period_s' must be a finite number",
        json.dumps({"t0_s": "1", "period_s": 0.03}): "'t0_s' must be a finite number",
        json.dumps({"t0_s": 1.0, "period_s": -0.03}): "'period_s': -0.03 is negative",
    }
    for i, (text, frag) in enumerate(cases.items()):
        with pytest.raises(InputError, match=frag):
            read_clock_document(_write_text(tmp_path, f"bad{i}.json", text))
    with pytest.raises(InputError, match="not found"):
        read_clock_document(tmp_path / "none.json")


def test_a_clock_file_reads_back_the_mount_it_was_fitted_with(tmp_path: Path) -> None:
    mount = Mount(lever_arm_body_m=(0.6, 0.0, -1.4), latency_s=0.005, profiler_azimuth_deg=30.0)
    recorded = ClockMount.of(mount, "m.toml")
    doc = {"t0_s": 12.5, "period_s": 0.03, "mount": recorded.as_document()}
    clock = read_clock_file(_write_text(tmp_path, "c.json", json.dumps(doc)))
    assert clock.mount == recorded
    assert recorded.differences(mount) == []
    assert recorded.differences(Mount(lever_arm_body_m=(0.6, 0.0, -1.4), latency_s=0.0)) == [
        "latency_s 0.005 (the clock's) vs 0.0",
        "[profiler] azimuth_deg 30.0 (the clock's) vs none",
    ]
    older = {"t0_s": 12.5, "period_s": 0.03}
    assert read_clock_file(_write_text(tmp_path, "old.json", json.dumps(older))).mount is None
    bad = {
        "[1]": "'mount' must be an object, got",
        '{"latency_s": 0}': "'mount' must name its file in 'path'",
        '{"path": "m.toml", "latency_s": "5 ms"}': "'mount' 'latency_s' must be a finite number",
        '{"path": "m", "latency_s": 0, "lever_arm_body_m": [1, 2]}': "'lever_arm_body_m' must be 3",
    }
    for i, (entry, frag) in enumerate(bad.items()):
        text = '{"t0_s": 1, "period_s": 0.03, "mount": ' + entry + "}"
        path = _write_text(tmp_path, f"m{i}.json", text)
        with pytest.raises(InputError, match=frag) as info:
            read_clock_file(path)
        assert str(info.value).startswith(f"{path}: ")


def test_a_local_clock_model_is_not_taken_for_a_profile_clock(tmp_path: Path) -> None:
    # `clock fit --model-out` writes a JSON too; it was refused as "'t0_s' must be a
    # finite number, got None".
    path = tmp_path / "model.json"
    model = ClockModel(
        reference_local_s=10.0, reference_gps_s=1.4e9, drift_ppm=3.0, span_local_s=(10.0, 20.0)
    )
    write_clock_model(model, path)
    with pytest.raises(InputError) as info:
        read_clock_document(path)
    message = str(info.value)
    assert message.startswith(f"{path}: not a profile clock: no t0_s or period_s (its keys: ")
    assert "drift_ppm" in message
    assert message.endswith("give the JSON that kinsync sync object-space --json writes")


def test_a_parquet_scan_names_the_row_from_one_of_all(tmp_path: Path) -> None:
    """Parquet has no lines: a bad profile number is ``row N of M``, counted from 1."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    n = 9
    profile = [0, 1, 2, 3, 4, 5, 6, 7, 2]  # the last row decreases
    cols = {"profile": profile, "angle_rad": [0.1] * n, "range_m": [2.0] * n}
    path = tmp_path / "scan.parquet"
    pq.write_table(pa.table(cols | {"intensity": [0.5] * n}), path, row_group_size=4)
    with pytest.raises(InputError, match=r"scan\.parquet: row 9 of 9, column 'profile': profile"):
        read_profile_scan(path)


def test_a_boolean_parquet_column_is_not_read_as_ones(tmp_path: Path) -> None:
    """A bool ``range_m`` column was read as 1.0 m for every true (float(True) is 1.0)."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    n = 4
    cols = {"profile": [0, 0, 1, 1], "angle_rad": [0.1] * n, "range_m": [True] * n}
    path = tmp_path / "scan.parquet"
    pq.write_table(pa.table(cols | {"intensity": [0.5] * n}), path)
    with pytest.raises(InputError, match=r"column 'range_m' holds true/false values"):
        read_profile_scan(path)


def test_a_float16_angle_column_is_refused_as_angles(tmp_path: Path) -> None:
    """It was refused as 'float16 coordinates near 1.70996 m ... 0.1 mm'."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    angle = np.array([0.1, 1.71, -0.5, 0.2])
    cols = {"profile": [0, 0, 1, 1], "range_m": [2.0] * 4, "intensity": [0.5] * 4}
    path = tmp_path / "scan.parquet"
    pq.write_table(pa.table(cols | {"angle_rad": angle.astype(np.float16)}), path)
    with pytest.raises(
        InputError, match=r"column 'angle_rad': float16 angles near 1\.70\d* rad .* 1 urad"
    ):
        read_profile_scan(path)
    pq.write_table(pa.table(cols | {"angle_rad": angle.astype(np.float32)}), path)
    np.testing.assert_array_equal(read_profile_scan(path).angle_rad, angle.astype(np.float32))


def test_float16_profile_numbers_and_intensities_are_judged_as_what_they_hold(
    tmp_path: Path,
) -> None:
    """Both were refused as 'float16 coordinates near 9 m ... 0.1 mm'.

    An intensity is a relative strength: float16 holds it well enough. Profile numbers are
    whole: float16 holds each one below 2048, and from there on skips some.
    """
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    cols = {"angle_rad": [0.1, 0.2, -0.5, 0.2], "range_m": [2.0] * 4}
    intensity = np.array([0.5, 0.25, 0.125, 0.3], dtype=np.float16)
    profile = np.array([0, 0, 2046, 2047], dtype=np.float16)
    path = tmp_path / "scan.parquet"
    pq.write_table(pa.table(cols | {"profile": profile, "intensity": intensity}), path)
    scan = read_profile_scan(path)
    np.testing.assert_array_equal(scan.intensity, intensity.astype(np.float64))
    np.testing.assert_array_equal(scan.profile, [0, 0, 2046, 2047])
    profile = np.array([0, 0, 3000, 3008], dtype=np.float16)
    pq.write_table(pa.table(cols | {"profile": profile, "intensity": intensity}), path)
    with pytest.raises(
        InputError,
        match=r"column 'profile': float16 whole numbers near 3008 are held in steps of 2, .*int64",
    ):
        read_profile_scan(path)


def test_an_ambiguous_clock_document_is_refused_unless_accepted(tmp_path: Path) -> None:
    """A clock file marked ambiguous (written by an older kinsync, or accepted once) may
    be whole seconds off: applying it needs the same explicit acceptance."""
    doc = {
        "t0_s": 1400000034.931,
        "period_s": 0.0303,
        "ambiguous": True,
        "alternatives": [{"t0_s": 1400000000.463}, {"t0_s": 1400000017.5}],
    }
    path = _write_text(tmp_path, "amb.json", json.dumps(doc))
    with pytest.raises(InputError) as info:
        read_clock_document(path)
    message = str(info.value)
    assert message.startswith(f"{path}: the clock is marked ambiguous")
    assert "t0 = 1400000000.463000, 1400000017.500000 s" in message
    assert "--accept-ambiguous" in message
    assert read_clock_document(path, accept_ambiguous=True) == (1400000034.931, 0.0303)
    settled = _write_text(tmp_path, "ok.json", json.dumps({**doc, "ambiguous": False}))
    assert read_clock_document(settled) == (1400000034.931, 0.0303)


def test_sync_points_cut_without_a_final_line_end_are_named(tmp_path: Path) -> None:
    """A sync-point file cut in half keeps its first rows: the last one is named."""
    text = "name,lat_deg,lon_deg,h_m\nS1,46.8,-71.2,10.0\nS2,46.8,-71.2,1"
    path = _write_text(tmp_path, "pts.csv", text)
    with pytest.warns(KinsyncWarning, match=r"pts\.csv: the file ends without a line end.*line 3"):
        read_sync_points(path)


@pytest.mark.parametrize(
    ("extra", "pattern"),
    [
        # alternatives 5 gave TypeError: 'int' object is not iterable (internal error)
        (
            '"period_s": 0.03, "ambiguous": true, "alternatives": 5',
            r"'alternatives' must be a list, got 5",
        ),
        # the string "true" was read as a settled clock
        ('"period_s": 0.03, "ambiguous": "true"', r"'ambiguous' must be true or false, got 'true'"),
        # Python's parser kept the last of two t0_s without a word
        (
            '"period_s": 0.03, "t0_s": 1400000099.0',
            r"not a valid clock file \(key 't0_s' is given twice",
        ),
        # said 'is >= 0', and then 0 was refused as 'at least 1e-05'
        ('"period_s": -0.03', r"-0\.03 is negative; a profile period .* is at least 1e-05 s"),
    ],
)
def test_a_malformed_clock_document_is_refused(tmp_path: Path, extra: str, pattern: str) -> None:
    path = _write_text(tmp_path, "c.json", f'{{"t0_s": 1400000000.5, {extra}}}')
    with pytest.raises(InputError, match=pattern):
        read_clock_document(path, accept_ambiguous=True)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_zero_ranges_are_named_with_a_warning_when_read(tmp_path: Path, suffix: str) -> None:
    """A range of 0 ("no return") is read, but named: `sync apply` will refuse it."""
    scan = _scan(n=20)
    rng = scan.range_m.copy()
    rng[[6, 9]] = 0.0
    path = tmp_path / f"scan{suffix}"
    write_profile_scan(
        ProfileScan(
            profile=scan.profile, angle_rad=scan.angle_rad, range_m=rng, intensity=scan.intensity
        ),
        path,
    )
    where = "line 8" if suffix == ".csv" else "row 7 of 20"
    with pytest.warns(KinsyncWarning, match=rf"{where}: range_m is 0 \(2 of 20 returns\).*apply"):
        back = read_profile_scan(path)
    np.testing.assert_array_equal(back.range_m, rng)


def test_a_scan_without_zero_ranges_reads_without_a_warning(tmp_path: Path) -> None:
    path = tmp_path / "scan.csv"
    write_profile_scan(_scan(n=20), path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_profile_scan(path)
