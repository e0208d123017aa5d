"""``kinsync calibrate mount`` on the 12 real CIDCO sphere passes (Port de Québec).

The passes were acquired with the mount the acquisition applied (`ACQUISITION_MOUNT`:
no boresight calibration); the vessel's attitude as DIN 9300 angles (the reader's
default). Each sphere is fitted to every pass with a free radius: where the passes
put its centre scatters by about 66 cm horizontally with that mount (29 cm in the
acquisition's own columns 1-3, which carry a pitch of the other sign). A boresight
calibration must bring that well under 10 cm without making the vertical worse, and
the latency and lever z must come back not determined: the vessel passed the spheres
at one speed, with little height change.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kinsync.cli import main
from kinsync.io.cidco import ACQUISITION_MOUNT
from kinsync.io.mount_file import read_mount, write_mount

DATA_DIR = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "cidco-port-de-quebec"
PASS_FILES = sorted(DATA_DIR.glob("sphere*/passage_*.txt")) if DATA_DIR.is_dir() else []
pytestmark = pytest.mark.skipif(
    len(PASS_FILES) != 12,
    reason=f"CIDCO Port de Québec data (12 pass files) not found under {DATA_DIR}",
)


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    out = capsys.readouterr()
    code = exc.value.code
    return (code if isinstance(code, int) else 0), out.out, out.err


def _prior_mount(folder: Path) -> Path:
    """The acquisition mount written to ``folder`` (the calibration's starting point)."""
    prior = folder / "acquisition.toml"
    write_mount(ACQUISITION_MOUNT, prior)
    return prior


def test_boresight_calibration_on_the_twelve_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    prior = _prior_mount(tmp_path)
    new = tmp_path / "calibrated.toml"
    code, out, err = _run(
        ["calibrate", "mount", "--points", *map(str, PASS_FILES), "--mount", str(prior),
         "--features", "spheres", "--estimate", "boresight,lever_z,latency",
         "--out", str(new), "--json"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert doc["sigma_method"].startswith("jackknife over 12 lines")
    assert doc["sigma_honest"] is True
    spheres = doc["features"]
    assert len(spheres) == 2
    for s in spheres:
        assert s["kind"] == "sphere"
        assert s["n_passes"] == 6
        before, after = s["scatter_before_m"], s["scatter_after_m"]
        assert before["horizontal"] > 0.25
        assert after["horizontal"] < 0.10
        assert after["vertical"] <= before["vertical"]
    params = doc["parameters"]
    assert params["latency_ms"]["status"] in ("unobservable", "weak")
    assert params["lever_z_m"]["status"] in ("unobservable", "weak")
    # The roll is determined (its sigma, about 0.02 deg, sits at the 'weak' threshold).
    assert params["boresight_roll_deg"]["status"] in ("estimated", "weak")
    assert params["boresight_roll_deg"]["std"] < 0.05
    assert (
        abs(params["boresight_roll_deg"]["value"] - 180.0) > 3 * params["boresight_roll_deg"]["std"]
    )
    for name in ("lever_x_m", "lever_y_m"):
        assert params[name]["status"] == "fixed"
    assert any("latency" in a for a in doc["advice"])
    assert doc["residual_rms_after_m"] < 0.2 * doc["residual_rms_before_m"]
    calibrated = read_mount(new)
    assert calibrated.boresight_rpy_deg[0] == pytest.approx(params["boresight_roll_deg"]["value"])
    assert calibrated.lever_arm_body_m == ACQUISITION_MOUNT.lever_arm_body_m


@pytest.mark.parametrize("passes", [(1, 2, 3, 4), (2, 3, 4, 5)])
def test_four_passes_with_the_latency_do_not_run_away(
    passes: tuple[int, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Each CIDCO pass carries its trajectory only 20 ms beyond its returns. On four
    # passes of one sphere the pitch and the latency are nearly one direction, and one
    # undamped step once took the latency to -945 ms (-699 ms on passes 2-5): every
    # return left its trajectory, the held weights' cost of those returns was zero, so
    # the step was taken, the "solution" used no return (n_points 0, residual NaN), and
    # every jackknife re-solve stayed there: sigma 0, status estimated, exit 0, a
    # mount with latency -0.945 s written. The latency must stay within what the
    # trajectories cover, come back not determined, and the boresight must agree with
    # the twelve passes' (pitch -7.68 +- 0.23 deg).
    prior = _prior_mount(tmp_path)
    new = tmp_path / "c4.toml"
    files = [str(DATA_DIR / "sphere1" / f"passage_{i}.txt") for i in passes]
    code, out, err = _run(
        ["calibrate", "mount", "--points", *files, "--mount", str(prior),
         "--features", "spheres", "--sphere-radius-m", "0.2", "--out", str(new), "--json"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    params = doc["parameters"]
    latency = params["latency_ms"]
    assert latency["status"] == "unobservable"
    assert latency["value"] == 0.0
    assert latency["std"] is None
    assert any("latency_ms" in u and "trajector" in u for u in doc["unobservable"])
    for name in ("boresight_roll_deg", "boresight_pitch_deg", "boresight_yaw_deg"):
        std = params[name]["std"]
        assert std is not None
        assert std > 0.0, name
        # A jackknife over 4 passes has 3 degrees of freedom: no honest sigma.
        assert params[name]["status"] == "weak", name
    pitch = params["boresight_pitch_deg"]
    assert abs(pitch["value"] - -7.68) < 3.0 * max(pitch["std"], 0.23)
    assert abs(params["boresight_roll_deg"]["value"] - 180.0) < 1.0
    (sphere,) = doc["features"]
    assert sphere["n_points"] > 100 * len(files)
    assert sphere["rms_after_m"] is not None
    assert sphere["rms_after_m"] < 0.1
    assert doc["residual_rms_after_m"] < 0.2 * doc["residual_rms_before_m"]
    assert read_mount(new).latency_s == 0.0


def test_three_passes_give_no_estimate_better_than_weak(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Three passes: no jackknife, the formal sigma. It once granted 'estimated' to a
    # pitch of -8.409 +- 0.015 deg, where the twelve passes give -7.68 +- 0.23 (50
    # formal sigmas away): an estimate resting on the formal sigma is at most weak,
    # and the advice says how many passes would give an honest sigma.
    prior = _prior_mount(tmp_path)
    files = [str(DATA_DIR / "sphere1" / f"passage_{i}.txt") for i in (1, 2, 3)]
    code, out, err = _run(
        ["calibrate", "mount", "--points", *files, "--mount", str(prior),
         "--features", "spheres", "--sphere-radius-m", "0.2", "--json"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert doc["sigma_method"].startswith("formal")
    assert doc["sigma_honest"] is False  # for a script: only prose said so
    statuses = {name: p["status"] for name, p in doc["parameters"].items()}
    assert "estimated" not in statuses.values()
    for name in ("boresight_roll_deg", "boresight_pitch_deg", "boresight_yaw_deg"):
        assert statuses[name] == "weak", name
    assert any("at least 5" in a and "3 given" in a for a in doc["advice"])


def test_a_pass_without_the_sphere_is_rejected_and_left_out_of_the_jackknife(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A pass with 3 returns and no sphere used to be counted as a sixth line by the
    # jackknife (5 degrees of freedom, +-2.57 sigma) while the sphere was seen by 5.
    prior = _prior_mount(tmp_path)
    folder = tmp_path / "e"
    folder.mkdir()
    empty = folder / "nosphere.txt"
    source = DATA_DIR / "sphere1" / "passage_3.txt"
    empty.write_text("".join(source.read_text().splitlines(keepends=True)[:3]))
    files = [str(DATA_DIR / "sphere1" / f"passage_{i}.txt") for i in (1, 2, 4, 5, 6)]
    files.insert(2, str(empty))
    code, out, err = _run(
        ["calibrate", "mount", "--points", *files, "--mount", str(prior),
         "--features", "spheres", "--sphere-radius-m", "0.2", "--json"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    (rejected,) = doc["rejected_lines"]
    assert rejected["line"] == "e/nosphere"
    assert "sphere" in rejected["reason"]
    assert "jackknife" in rejected["reason"]
    assert "e/nosphere" not in doc["lines"]
    assert len(doc["lines"]) == 5
    assert doc["features"][0]["n_passes"] == 5
    assert doc["sigma_method"].startswith("jackknife over 5 lines")
    assert "4 degrees of freedom" in doc["sigma_method"]
