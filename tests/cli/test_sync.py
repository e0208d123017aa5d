"""``kinsync sync object-space / apply`` and ``kinsync simulate drive-scan``."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest

import kinsync.sync
from kinsync.cli import _output
from kinsync.frames import geodetic_to_ecef
from kinsync.io.mount_file import write_mount
from kinsync.mount import Mount, MountUncertainty
from kinsync.sim.profiler import (
    DriveScanConfig,
    DriveScanSimulation,
    simulate_drive_scan,
    write_drive_scan,
)

RunCli = Callable[[list[str]], tuple[int, str, str]]  # fixture run_cli in conftest.py
OneLineError = Callable[..., None]  # fixture assert_one_line_error in conftest.py


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> tuple[DriveScanSimulation, Path]:
    sim = simulate_drive_scan(DriveScanConfig(near_targets_only=True, extra_first_pulse=True))
    folder = tmp_path_factory.mktemp("drive-scan")
    write_drive_scan(sim, folder)
    return sim, folder


def _object_space(folder: Path, *extra: str) -> list[str]:
    return [
        "sync",
        "object-space",
        "--scan",
        str(folder / "scan.csv"),
        "--trajectory",
        str(folder / "trajectory.csv"),
        "--mount",
        str(folder / "mount.toml"),
        "--sync-points",
        str(folder / "sync_points.csv"),
        *extra,
    ]


def test_object_space_json(run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path]) -> None:
    sim, folder = dataset
    args = _object_space(folder, "--pulses", str(folder / "pulses.csv"))
    code, out, err = run_cli([*args, "--position-std-m", "0", "--json"])
    assert code == 0, err
    assert out.count("\n") == 1
    doc = json.loads(out)
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) < 4 * doc["t0_std_s"]
    assert abs(doc["period_s"] - sim.truth["period_s"]) < 4 * doc["period_std_s"]
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) < 2e-3
    assert doc["pulse_offset"] == 1
    assert doc["pulse_offset_sure"] is True
    assert len(doc["residuals_s"]) == len(doc["sightings"]) >= 4
    for s in doc["sightings"]:
        assert {"name", "profile", "angle_rad", "t_s"} <= set(s)
        assert s["name"] in ("S1", "S2")
    assert doc["ambiguous"] is False


def test_object_space_holds_the_mounts_stated_errors(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path
) -> None:
    """The mount's [uncertainty] is in the clock's sigma; without it a warning says so."""
    sim, folder = dataset
    code, out, err = run_cli([*_object_space(folder), "--json"])
    assert code == 0, err
    exact = json.loads(out)
    assert exact["t0_std_s"] == exact["t0_std_data_s"]
    assert "lever_x_m" in exact["mount_effect"]["exact"]
    assert "kinsync: warning: the clock's sigma takes the mount as exact where it gives no " in err
    assert "1 cm of lever_x_m moves t0 by -" in err
    unc = MountUncertainty(
        lever_arm_body_m=(0.02, 0.02, 0.02), boresight_rpy_deg=(0.5, 0.5, 0.5), latency_s=0.001
    )
    stated = tmp_path / "mount.toml"
    write_mount(dataclasses.replace(sim.config.mount, uncertainty=unc), stated)
    args = _object_space(folder)
    args[args.index(str(folder / "mount.toml"))] = str(stated)
    code, out, err = run_cli(args)
    assert code == 0, err
    assert "takes the mount as exact" not in err
    assert "of which the mount's (ms)" in out
    assert "of which the mount's (us)" in out
    code, out, err = run_cli([*args, "--json"])
    doc = json.loads(out)
    assert doc["t0_s"] == exact["t0_s"]
    assert doc["t0_std_data_s"] == pytest.approx(exact["t0_std_s"])
    assert doc["t0_std_s"] ** 2 == pytest.approx(
        doc["t0_std_data_s"] ** 2 + doc["mount_effect"]["t0_std_s"] ** 2
    )
    assert doc["t0_std_s"] > 2.0 * doc["t0_std_data_s"]
    assert doc["mount_effect"]["exact"] == []


@pytest.mark.parametrize("width", [80, 60])
def test_object_space_table(
    run_cli: RunCli,
    dataset: tuple[DriveScanSimulation, Path],
    monkeypatch: pytest.MonkeyPatch,
    width: int,
) -> None:
    _, folder = dataset
    monkeypatch.setattr(_output.console, "width", width)
    code, out, err = run_cli(_object_space(folder))
    assert code == 0, err
    assert "t0 (s)" in out
    assert "period sigma (us)" in out
    assert "S1" in out
    assert "S2" in out
    # Every sighting time in full on a narrow terminal (they were cut to "1400000014…").
    assert "…" not in out
    code, doc_text, err = run_cli([*_object_space(folder), "--json"])
    times = [f"{s['t_s']:.4f}" for s in json.loads(doc_text)["sightings"]]
    assert len(times) >= 4
    for t in times:
        assert f" {t} " in out, (t, out)


def test_object_space_refuses_a_wrong_period_prior(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
) -> None:
    """A prior 9 % off gave exit 0 and a clock from 2 of 18 sightings matched by chance."""
    sim, folder = dataset
    code, out, err = run_cli([*_object_space(folder), "--period-prior-s", "0.0333"])
    assert_one_line_error(
        code,
        out,
        err,
        "--period-prior-s 0.0333 s: ",
        " of 18 sightings fit a clock with a period within 1 % of it, 6 fit one",
        f"period of {sim.truth['period_s']:.4g}",
        "datasheet or log",
        "widen --period-tolerance to 0.09",
    )
    code, out, err = run_cli([*_object_space(folder), "--period-prior-s", "0.0308", "--json"])
    assert code == 0, err
    assert len(json.loads(out)["sightings"]) == 6


def test_object_space_warns_of_a_clock_from_two_sightings(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path
) -> None:
    """S2 alone, passed twice: two pairs fit any line, nothing checks them.

    Other pairs of crossings fit as well: the best was 97 s late, exit 0; it is refused
    as ambiguous now, and the pulses pick the true one (with the warning still).
    """
    sim, folder = dataset
    lines = (folder / "sync_points.csv").read_text().splitlines()
    only_s2 = tmp_path / "s2.csv"
    only_s2.write_text("\n".join([lines[0], *(x for x in lines if x.startswith("S2,"))]) + "\n")
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(only_s2)
    code, out, err = run_cli([*args, "--json"])
    assert code == 2, err
    assert f"kinsync: error: {only_s2}: ambiguous: " in err
    code, out, err = run_cli([*args, "--json", "--pulses", str(folder / "pulses.csv")])
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["sightings"]) == 2
    assert doc["settled_by_pulses"] is True
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) < 3 * doc["t0_std_s"]
    assert "kinsync: warning: the clock rests on 2 of 18 sightings: " in err


def test_object_space_warns_of_sync_points_off_or_never_crossed(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path
) -> None:
    """Sync points 0.5 m east (a datum mix-up) and one 1.1 km away, named by file line.

    t0 came out 140 ms (7 sigma) off with exit 0 and nothing on stderr; F1 vanished.
    """
    _, folder = dataset
    header, *rows = (folder / "sync_points.csv").read_text().splitlines()
    moved = []
    for row in rows:
        name, lat, lon, h = row.split(",")
        moved.append(f"{name},{lat},{float(lon) + 0.5 / 76200.0!r},{h}")
    name, lat, lon, h = rows[0].split(",")
    points = tmp_path / "sp.csv"
    points.write_text("\n".join([header, *moved, f"F1,{float(lat) + 0.01!r},{lon},{h}"]) + "\n")
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(points)
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    assert f"kinsync: warning: {points}: sync point 'F1' (line 4) is never crossed " in err
    assert f"kinsync: warning: {points}: 2 sighting(s) lie near crossings of sync points " in err
    assert "'S1' at profile 459." in err
    doc = json.loads(out)
    assert doc["n_crossings"]["F1"] == 0
    assert sum(u["near_crossing_of"] is not None for u in doc["unmatched_sightings"]) == 2


def test_an_ambiguous_clock_is_refused_unless_the_pulses_settle_it_or_it_is_accepted(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
) -> None:
    """Sync-point heights 0.5 m off: t0 34 s late, exit 0, 'ambiguous' only a warning.

    The GPS-timed pulses contradicted that clock by 1128 profiles, and sync apply took
    the file as it was.
    """
    sim, folder = dataset
    lines = (folder / "sync_points.csv").read_text().splitlines()
    off = tmp_path / "sp_h.csv"
    rows = [line.split(",") for line in lines[1:]]
    off.write_text(
        "\n".join([lines[0], *(",".join([*r[:3], repr(float(r[3]) + 0.5)]) for r in rows)]) + "\n"
    )
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(off)
    code, out, err = run_cli([*args, "--json"])
    assert_one_line_error(
        code,
        out,
        err,
        f"{off}: ambiguous: 5 other match(es) of sightings to sync-point crossings fit almost as "
        "well as the best, t0 = ",
        "(others: t0 = ",
        "; the best rests on 2 of 18 sightings, which any line fits, and 3 of the others each "
        "match one sighting it leaves out alone (with its period): ",
        "give --pulses (the scanner's GPS-timed profile pulses)",
        "or take the best with --accept-ambiguous",
    )
    code, out, err = run_cli([*args, "--json", "--accept-ambiguous"])
    assert code == 0, err
    assert json.loads(out)["ambiguous"] is True
    assert "kinsync: warning: ambiguous: 5 other assignment(s) of sightings to crossings" in err
    code, out, err = run_cli([*args, "--pulses", str(folder / "pulses.csv"), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert (doc["ambiguous"], doc["settled_by_pulses"], doc["pulse_offset"]) == (False, True, 1)
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) < 3 * doc["t0_std_s"]
    assert f"kinsync: warning: {folder / 'pulses.csv'}: the pulses contradict the clock" in err
    assert "one agrees with the pulses (pulse offset 1) and is taken" in err
    code, out, err = run_cli([*args, "--pulses", str(folder / "pulses.csv")])
    assert code == 0, err
    assert "no (settled by the pulses)" in out


def test_a_clock_from_two_sightings_that_leave_one_out_is_refused(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
) -> None:
    """S2 alone, the scan ending before its second pass: t0 was 132 s late, exit 0.

    Two sightings of S1 a lap apart fitted S2's two crossings, "ambiguous: no"; the one
    true sighting of S2, left out, matched alone gives the true clock.
    """
    sim, folder = dataset
    lines = (folder / "sync_points.csv").read_text().splitlines()
    only_s2 = tmp_path / "s2.csv"
    only_s2.write_text("\n".join([lines[0], *(x for x in lines if x.startswith("S2,"))]) + "\n")
    header, *rows = (folder / "scan.csv").read_text().splitlines()
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join([header, *(r for r in rows if int(r.split(",")[0]) < 6000)]) + "\n")
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(only_s2)
    args[args.index("--scan") + 1] = str(cut)
    code, out, err = run_cli([*args, "--json"])
    assert_one_line_error(
        code,
        out,
        err,
        f"{only_s2}: ambiguous: ",
        "the best rests on 2 of ",
        "each match one sighting it leaves out alone (with its period)",
        "give --pulses",
        "pass each sync point at the start and at the end of the drive",
    )
    code, out, err = run_cli([*args, "--json", "--accept-ambiguous"])
    assert code == 0, err
    doc = json.loads(out)
    assert doc["ambiguous"] is True
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) > 100.0
    truth = [a for a in doc["alternatives"] if abs(a["t0_s"] - sim.truth["t0_s"]) < 0.05]
    assert [a["n_matched"] for a in truth] == [1], doc["alternatives"]


def test_an_ambiguity_with_sync_points_seen_off_the_clock_says_what_to_check(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Sightings at their sync points' crossings that fit no clock: check the geometry.

    With the plane slanted 20 deg, sightings of two of four sync points (one pass each,
    at the start and the end) fit no line and the clock was ambiguous: the advice was to
    pass each sync point at the start and the end of the drive, which had been done.
    Here S2 is 0.26 m north and east off (its two sightings fit no line) and the clock is made
    ambiguous; the message names S2 and the mount and coordinates to check instead.
    """
    _, folder = dataset
    lines = (folder / "sync_points.csv").read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    for r in rows:  # S2 0.26 m north and east
        if r[0] == "S2":
            lat = float(r[1])
            r[1] = repr(lat + math.degrees(0.26 / 6_378_137.0))
            east_deg = math.degrees(0.26 / (6_378_137.0 * math.cos(math.radians(lat))))
            r[2] = repr(float(r[2]) + east_deg)
    moved = tmp_path / "sp_s2.csv"
    moved.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    real = kinsync.sync.synchronise_object_space

    def ambiguous(*args: Any, **kwargs: Any) -> kinsync.sync.ObjectSpaceResult:
        result = real(*args, **kwargs)
        rival = kinsync.sync.Alternative(result.t0_s + 30.0, result.period_s, 4, 1.0)
        return dataclasses.replace(result, ambiguous=True, alternatives=(rival,))

    monkeypatch.setattr(kinsync.sync, "synchronise_object_space", ambiguous)
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(moved)
    code, out, err = run_cli([*args, "--json"])
    assert_one_line_error(
        code,
        out,
        err,
        f"{moved}: ambiguous: 1 other match(es) of sightings to sync-point crossings",
        "2 sighting(s) lie where the scan plane crosses sync point(s) S2 but fit none of "
        "these clocks: check the mount (lever arm, boresight, latency, [profiler] "
        "azimuth_deg) and the sync points' coordinates (heights too)",
        "give --pulses",
        "or take the best with --accept-ambiguous",
    )
    assert "pass each sync point" not in err
    monkeypatch.setattr(kinsync.sync, "synchronise_object_space", real)
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    assert [u["at_crossing_of"] for u in doc["unmatched_sightings"]].count("S2") == 2


def test_a_gap_in_the_pulses_is_named_by_file_line_and_time(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
) -> None:
    """Lines 5000-5004 cut out (an empty line left in): 'pulse 4998 comes 6.00 periods
    after pulse 4997' named neither the file nor its lines, and counted from 0."""
    sim, folder = dataset
    lines = (folder / "pulses.csv").read_text().splitlines()
    cut = tmp_path / "p_gap.csv"
    cut.write_text("\n".join([*lines[:10], "", *lines[10:4999], *lines[5004:]]) + "\n")
    t = sim.pulses_t_s
    code, out, err = run_cli([*_object_space(folder, "--pulses", str(cut)), "--json"])
    assert_one_line_error(
        code,
        out,
        err,
        f"{cut}: pulses at t_s={float(t[4997])!r} (line 5000) and ",
        f"t_s={float(t[5003])!r} (line 5001) are 6.00 periods apart: about 5 pulse(s) missing",
        "fill the gap or cut the scan there",
    )


def test_object_space_leaves_out_a_crossing_in_a_trajectory_gap(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path
) -> None:
    """10 s cut out of the trajectory around a sighting: exit 0, the crossing named in
    one warning line and in the document, the sighting unmatched (it was an internal
    error: the root search met the gap-aware georeferencing's NaN)."""
    sim, folder = dataset
    code, out, err = run_cli([*_object_space(folder), "--json"])
    assert code == 0, err
    full = json.loads(out)
    first = full["sightings"][0]
    lines = (folder / "trajectory.csv").read_text().splitlines()
    kept = [ln for ln in lines[1:] if abs(float(ln.split(",")[0]) - first["t_s"]) > 5.0]
    holed = tmp_path / "trajectory_hole.csv"
    holed.write_text("\n".join([lines[0], *kept]) + "\n")
    args = _object_space(folder)
    args[args.index(str(folder / "trajectory.csv"))] = str(holed)
    code, out, err = run_cli([*args, "--json"])
    assert code == 0, err
    doc = json.loads(out)
    (gap,) = doc["crossings_in_gaps"]
    assert gap["name"] == first["name"]
    assert gap["t_start_s"] < first["t_s"] < gap["t_end_s"]
    assert len(doc["sightings"]) == len(full["sightings"]) - 1
    assert len(doc["unmatched_sightings"]) == len(full["unmatched_sightings"]) + 1
    assert abs(doc["t0_s"] - sim.truth["t0_s"]) < 4 * doc["t0_std_s"]
    warnings = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(warnings) == 1
    assert f"{holed}: 1 possible sync-point crossing(s) left out" in warnings[0]
    assert f"{first['name']} in " in warnings[0]
    # the threshold used (10 median record intervals) and the option that sets it
    t_rec = np.array([float(ln.split(",")[0]) for ln in kept])
    limit = 10.0 * float(np.median(np.diff(t_rec)))
    assert doc["gap_threshold_s"] == pytest.approx(limit)
    shown = round(10.0 * round(limit / 10.0, 6), 6)  # as people are shown it: to 1 us
    assert (
        f"record intervals longer than {shown:.6g} s (the gap threshold: --max-gap-s"
        in (warnings[0])
    )
    # a threshold above the hole: the crossing is searched across it, nothing left out
    length = gap["t_end_s"] - gap["t_start_s"]
    code, out, err = run_cli([*args, "--max-gap-s", f"{length + 0.5:.3f}", "--json"])
    assert code == 0, err
    assert "data gaps" not in err
    # but the trajectory guessed across the hole puts that crossing 0.5 m off: its
    # sighting is left out, and named as seen near the crossing
    (near,) = [ln for ln in err.splitlines() if "warning" in ln]
    assert "1 sighting(s) lie near crossings of sync points that the clock leaves out" in near
    assert "the trajectory there may be off" in near
    doc = json.loads(out)
    assert doc["gap_threshold_s"] == pytest.approx(length + 0.5, abs=1e-3)
    assert doc["crossings_in_gaps"] == []
    assert doc["n_crossings"] == full["n_crossings"]


def test_apply_then_georeference(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path
) -> None:
    sim, folder = dataset
    code, out, err = run_cli([*_object_space(folder, "--position-std-m", "0"), "--json"])
    assert code == 0, err
    clock = tmp_path / "clock.json"
    clock.write_text(out)
    doc = json.loads(out)
    timed = tmp_path / "timed.csv"
    base = ["sync", "apply", "--scan", str(folder / "scan.csv"), "--mount"]
    code, out, err = run_cli(
        [*base, str(folder / "mount.toml"), "--out", str(timed), "--clock", str(clock), "--json"]
    )
    assert code == 0, err
    assert json.loads(out)["points"] == len(sim.scanner.scan)
    table = pa_csv.read_csv(timed)
    assert table.column_names == [
        "profile",
        "angle_rad",
        "range_m",
        "intensity",
        "t_s",
        "x_m",
        "y_m",
        "z_m",
    ]
    t = table.column("t_s").to_numpy()
    # The clock error is a fraction of a millisecond, within its sigma.
    assert np.max(np.abs(t - sim.scanner.t_s)) < 4 * doc["t0_std_s"] + 1e-3
    same = tmp_path / "same.csv"
    code, _, err = run_cli(
        [
            *base,
            str(folder / "mount.toml"),
            "--out",
            str(same),
            "--t0-s",
            repr(doc["t0_s"]),
            "--period-s",
            repr(doc["period_s"]),
        ]
    )
    assert code == 0, err
    assert same.read_text() == timed.read_text()
    # Georeferenced with the recovered clock, the S1 returns lie on the S1 sphere.
    geo = tmp_path / "geo.csv"
    code, _, err = run_cli(
        [
            "georef",
            "--points",
            str(timed),
            "--trajectory",
            str(folder / "trajectory.csv"),
            "--mount",
            str(folder / "mount.toml"),
            "--out",
            str(geo),
            "--point-columns",
            "xyz",
        ]
    )
    assert code == 0, err
    g = pa_csv.read_csv(geo)
    xyz = np.column_stack([g.column(c).to_numpy() for c in ("X", "Y", "Z")])
    s1 = geodetic_to_ecef(*sim.sync_points.lat_lon_h[0])
    dist = np.linalg.norm(xyz - s1, axis=1)
    on = dist < 0.5
    assert on.sum() >= 16
    radius = sim.config.layout.target_radius_m
    assert np.abs(dist[on] - radius).max() < 0.015


def test_the_clock_records_its_mount_and_apply_refuses_another(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
) -> None:
    """The clock holds the mount's latency (t0 moves with it 1:1); clock.json said nothing
    of the mount, and apply with a 5 ms mount, then georef with it, moved points by up to
    55 mm with exit 0. Now the clock names its mount and apply refuses another."""
    sim, folder = dataset
    code, out, err = run_cli([*_object_space(folder, "--position-std-m", "0"), "--json"])
    assert code == 0, err
    doc = json.loads(out)
    mount = sim.config.mount
    assert doc["mount"] == {
        "path": str(folder / "mount.toml"),
        "latency_s": mount.latency_s,
        "lever_arm_body_m": list(mount.lever_arm_body_m),
        "boresight_rpy_deg": list(mount.boresight_rpy_deg),
        "profiler_azimuth_deg": mount.profiler_azimuth_deg,
    }
    clock = tmp_path / "clock.json"
    clock.write_text(out)
    late = tmp_path / "late.toml"
    write_mount(dataclasses.replace(mount, latency_s=mount.latency_s + 0.005), late)
    timed = tmp_path / "timed.csv"
    base = ["sync", "apply", "--scan", str(folder / "scan.csv"), "--clock", str(clock)]
    base += ["--out", str(timed), "--mount"]
    assert_one_line_error(
        *run_cli([*base, str(late)]),
        f"{clock}: the clock was fitted with mount {folder / 'mount.toml'}",
        f"latency_s {mount.latency_s!r} (the clock's) vs {mount.latency_s + 0.005!r}",
        f"give --mount {folder / 'mount.toml'}",
        f"sync object-space --mount {late} --json",
    )
    assert not timed.exists()
    turned = tmp_path / "turned.toml"
    yaw = (*mount.boresight_rpy_deg[:2], mount.boresight_rpy_deg[2] + 0.1)
    write_mount(dataclasses.replace(mount, boresight_rpy_deg=yaw), turned)
    assert_one_line_error(*run_cli([*base, str(turned)]), "boresight_rpy_deg [")
    # The same values under another name (a copy, stated sigma aside) are the same mount.
    copy = tmp_path / "copy.toml"
    write_mount(mount, copy)
    code, _, err = run_cli([*base, str(copy)])
    assert code == 0, err
    assert "warning" not in err
    # An older clock file, without the mount: read, with a warning saying what to do.
    del doc["mount"]
    clock.write_text(json.dumps(doc))
    code, out, err = run_cli([*base, str(copy), "--json"])
    assert code == 0, err
    (line,) = err.splitlines()
    assert line.startswith(f"kinsync: warning: {clock}: the clock file does not record the mount")
    assert "georeference these points with that same mount" in line
    assert json.loads(out)["warnings"] == [line.removeprefix("kinsync: warning: ")]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_apply_to_a_scan_without_rows_writes_a_table_georef_reads(
    run_cli: RunCli, dataset: tuple[DriveScanSimulation, Path], tmp_path: Path, suffix: str
) -> None:
    """A header-only scan gave a 0-byte output with exit 0, which kinsync then refused
    ("empty file; expected a header line"); now every column and no row, as georef."""
    _, folder = dataset
    scan = tmp_path / "h.csv"
    scan.write_text((folder / "scan.csv").read_text().splitlines()[0] + "\n")
    clock = tmp_path / "clock.json"
    clock.write_text('{"t0_s": 1400000000.4, "period_s": 0.0303}')
    timed = tmp_path / f"timed{suffix}"
    mount = str(folder / "mount.toml")
    apply = ["sync", "apply", "--scan", str(scan), "--mount", mount, "--clock", str(clock)]
    code, out, err = run_cli([*apply, "--out", str(timed), "--json"])
    assert code == 0, err
    assert json.loads(out)["points"] == 0
    table = pq.read_table(timed) if suffix == ".parquet" else pa_csv.read_csv(timed)
    assert table.num_rows == 0
    assert table.column_names[-4:] == ["t_s", "x_m", "y_m", "z_m"]
    geo = tmp_path / "geo.csv"
    georef = ["georef", "--points", str(timed), "--trajectory", str(folder / "trajectory.csv")]
    georef += ["--mount", mount, "--out", str(geo), "--point-columns", "xyz", "--json"]
    code, out, err = run_cli(georef)
    assert code == 0, err
    assert json.loads(out)["points_in"] == 0
    assert pa_csv.read_csv(geo).num_rows == 0


def test_simulate_drive_scan(run_cli: RunCli, tmp_path: Path) -> None:
    out = tmp_path / "sim"
    code, stdout, err = run_cli(
        [
            "simulate",
            "drive-scan",
            "--out",
            str(out),
            "--duration-s",
            "60",
            "--near-targets-only",
            "--extra-first-pulse",
            "--period-s",
            "0.0301",
            "--json",
        ]
    )
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc["pulse_offset"] == 1
    assert doc["period_s"] == 0.0301
    assert set(doc["passes"]) == {"S1", "S2", "C1", "C2", "C3", "C4"}
    for name in doc["files"]:
        assert (out / name).is_file(), name
    truth = json.loads((out / "truth.json").read_text())
    assert truth["n_profiles"] == doc["n_profiles"]
    code, stdout, err = run_cli(
        ["simulate", "drive-scan", "--out", str(tmp_path / "b"), "--duration-s", "45"]
    )
    assert code == 0, err
    assert "passes of S1" in stdout


def test_bad_input(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    dataset: tuple[DriveScanSimulation, Path],
    tmp_path: Path,
) -> None:
    _, folder = dataset
    plain = tmp_path / "plain.toml"
    write_mount(Mount(), plain)
    args = _object_space(folder)
    args[args.index("--mount") + 1] = str(plain)
    assert_one_line_error(*run_cli(args), "[profiler] azimuth_deg")
    far = tmp_path / "far.csv"
    far.write_text("name,lat_deg,lon_deg,h_m\nS1,10.0,20.0,0.0\nS2,10.0,20.001,0.0\n")
    args = _object_space(folder)
    args[args.index("--sync-points") + 1] = str(far)
    assert_one_line_error(*run_cli(args), "far.csv", "'S1' lies", "km")
    args = _object_space(folder)
    args[args.index("--scan") + 1] = str(tmp_path / "none.csv")
    assert_one_line_error(*run_cli(args), "none.csv", "not found")
    assert_one_line_error(
        *run_cli([*_object_space(folder), "--period-tolerance", "0.7"]), "--period-tolerance"
    )
    assert_one_line_error(
        *run_cli([*_object_space(folder), "--position-corr-time-s", "-1"]), "--position-corr-time-s"
    )
    scan = str(folder / "scan.csv")
    mount = str(folder / "mount.toml")
    out = str(tmp_path / "o.csv")
    base = ["sync", "apply", "--scan", scan, "--mount", mount, "--out", out]
    assert_one_line_error(*run_cli(base), "--t0-s and --period-s, or --clock")
    clock = tmp_path / "c.json"
    clock.write_text("{")
    assert_one_line_error(*run_cli([*base, "--clock", str(clock), "--t0-s", "1"]), "not both")
    assert_one_line_error(*run_cli([*base, "--clock", str(clock)]), "c.json", "not valid JSON")
    # A clock file marked ambiguous: refused unless accepted; the option needs --clock.
    clock.write_text('{"t0_s": 1400000000.4, "period_s": 0.0303, "ambiguous": true}')
    assert_one_line_error(*run_cli([*base, "--clock", str(clock)]), "marked ambiguous")
    assert not Path(out).exists()
    assert_one_line_error(
        *run_cli([*base, "--t0-s", "1", "--period-s", "0.03", "--accept-ambiguous"]),
        "--accept-ambiguous applies to a --clock file",
    )
    assert_one_line_error(
        *run_cli([*base, "--t0-s", "1", "--period-s", "0"]), "--period-s 0: outside"
    )
    timed = tmp_path / "timed.csv"
    timed.write_text("profile,angle_rad,range_m,t_s\n0,0.1,2.0,5.0\n")
    bad = ["sync", "apply", "--scan", str(timed), "--mount", mount, "--out", out]
    assert_one_line_error(*run_cli([*bad, "--t0-s", "1", "--period-s", "0.03"]), "already has")
    assert not Path(out).exists()
    sim = ["simulate", "drive-scan", "--out", str(tmp_path / "s")]
    assert_one_line_error(*run_cli([*sim, "--route", "square"]), "--route")
    assert_one_line_error(
        *run_cli([*sim, "--duration-s", "10"]), "--duration-s 10: outside the span", "40 to 7200 s"
    )
    # It ran until killed (8e9 beams): the size is estimated before any work.
    assert_one_line_error(
        *run_cli([*sim, "--period-s", "1e-5"]),
        "--duration-s 300 at --period-s 1e-05: 30,000,000 profiles of 271 beams",
        "give a shorter --duration-s or a longer --period-s",
    )
    assert_one_line_error(*run_cli(["simulate", "drive-scan", "--out", str(timed)]), "not a folder")


def test_apply_carries_parquet_types_and_refuses_a_null_range(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    mount = tmp_path / "mount.toml"
    write_mount(Mount(profiler_azimuth_deg=0.0), mount)
    scan = pa.table(
        {
            "profile": pa.array([0, 0, 1, 1, 2], pa.int32()),
            "angle_rad": [0.1, 0.2, 0.1, 0.2, 0.1],
            "range_m": [2.0, 2.0, 3.0, 3.0, 4.0],
            "intensity": pa.array([1, 2, None, 4, 5], pa.int32()),
            "flag": [True, False, None, True, False],
        }
    )
    src = tmp_path / "scan.parquet"
    pq.write_table(scan, src, row_group_size=2)
    clock = ["--t0-s", "0", "--period-s", "0.1", "--chunk-points", "3"]
    base = ["sync", "apply", "--scan", str(src), "--mount", str(mount), *clock, "--out"]
    code, _, err = run_cli([*base, str(tmp_path / "o.parquet")])
    assert code == 0, err
    got = pq.read_table(tmp_path / "o.parquet")
    assert got.select(scan.column_names).equals(scan)
    code, _, err = run_cli([*base, str(tmp_path / "o.csv")])
    assert code == 0, err
    rows = [line.split(",")[:5] for line in (tmp_path / "o.csv").read_text().splitlines()]
    assert [r[0] for r in rows[1:]] == ["0", "0", "1", "1", "2"]
    assert [r[3] for r in rows[1:]] == ["1", "2", "", "4", "5"]
    assert [r[4] for r in rows[1:]] == ["true", "false", "", "true", "false"]
    holed = tmp_path / "holed.parquet"
    pq.write_table(scan.set_column(2, "range_m", pa.array([2.0, 2.0, 3.0, None, 4.0])), holed)
    args = [*base, str(tmp_path / "h.csv")]
    args[args.index("--scan") + 1] = str(holed)
    assert_one_line_error(*run_cli(args), "holed.parquet: row 4 of 5, column 'range_m': no value")
    assert not (tmp_path / "h.csv").exists()
