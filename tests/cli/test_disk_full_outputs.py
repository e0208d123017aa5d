"""A full disk met by outputs written in several steps or by a library (lazrs, numpy).

Each ended otherwise than the one disk-full line (exit 2, the output named, nothing
partial left): lazrs reports a failed write as ``LazrsError: IoError: Failed to call
write`` (internal error, exit 1), numpy's ``tofile`` as ``N requested and M written``
without an error number, and LAS/PLY writes as a bare ``cannot write``. A LAZ output
failing at its last chunk had its rejected file already renamed onto the earlier one;
the second of two outputs failing did not say that the first had replaced its file.
The disk is made full by the file objects the writers write to, so no small file system
is needed.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import pytest
from laspy._compression.lazrsbackend import LazrsPointWriter
from tests._georef_scan import scan_columns, write_laz, write_trajectory

from kinsync.errors import InputError
from kinsync.io.passes import write_passes
from kinsync.io.sbet import write_sbet
from kinsync.latency.passes import SpherePass
from kinsync.trajectory import Trajectory

RunCli = Callable[[list[str]], tuple[int, str, str]]
OneLineError = Callable[..., None]


def _full() -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


class _FullDisk:
    """A file whose writes fail with ENOSPC once `full` is set, or from one of `room` bytes."""

    def __init__(self, fh: Any, room: int | None) -> None:
        self._fh = fh
        self.room = room
        self.full = False

    def write(self, data: Any) -> int:
        if self.full or (self.room is not None and memoryview(data).nbytes >= self.room):
            raise _full()
        return int(self._fh.write(data))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._fh, name)

    def __enter__(self) -> _FullDisk:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._fh.close()


def _fill_disk_of(
    monkeypatch: pytest.MonkeyPatch, name: str, room: int | None = None
) -> list[_FullDisk]:
    """Files opened to write ``name`` (its temporary) get a disk that fills up.

    With ``room``, at a write of that many bytes or more; else when a LAZ writer writes
    its last chunk and chunk table (``LazrsPointWriter.done``, where lazrs writes a small
    file whole).
    """
    opened: list[_FullDisk] = []
    real_open = Path.open

    def open_full(self: Path, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        fh = real_open(self, mode, *args, **kwargs)
        if "w" in mode and self.name.startswith(f".{name}.{os.getpid()}."):
            opened.append(_FullDisk(fh, room))
            return opened[-1]
        return fh

    real_done = LazrsPointWriter.done

    def done(self: LazrsPointWriter) -> None:
        for f in opened:
            f.full = True
        real_done(self)

    monkeypatch.setattr(Path, "open", open_full)
    monkeypatch.setattr(LazrsPointWriter, "done", done)
    return opened


def _no_temporaries(folder: Path) -> None:
    assert not [p.name for p in folder.iterdir() if p.name.endswith(".part")]


@pytest.fixture
def survey(tmp_path: Path) -> dict[str, Path]:
    """A LAZ scan (some points before the trajectory starts), its trajectory and mount."""
    write_trajectory(tmp_path / "traj.csv", 4.0)
    write_laz(scan_columns(300, 3.0, 1), tmp_path / "scan.laz")
    (tmp_path / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    return {"dir": tmp_path, "points": tmp_path / "scan.laz", "traj": tmp_path / "traj.csv"}


def _georef(survey: dict[str, Path], out: Path, *extra: str) -> list[str]:
    return [
        *["georef", "--points", str(survey["points"]), "--trajectory", str(survey["traj"])],
        *["--mount", str(survey["dir"] / "m.toml"), "--out", str(out), *extra],
    ]


def test_a_laz_output_full_at_its_last_chunk_leaves_both_earlier_files(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    survey: dict[str, Path],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The rejected file was renamed into place before the output's last chunk failed."""
    folder = survey["dir"]
    out, rejected = folder / "geo.laz", folder / "geo.rejected.laz"
    out.write_bytes(b"earlier output")
    rejected.write_bytes(b"earlier rejects")
    _fill_disk_of(monkeypatch, "geo.laz")
    code, stdout, err = run_cli(_georef(survey, out, "--outside", "reject"))
    last = err.splitlines()[-1]  # warnings (the rejected points) come before it
    assert_one_line_error(code, stdout, last + "\n", f"--out {out}", "disk is full")
    assert "written before it" not in last
    assert out.read_bytes() == b"earlier output"
    assert rejected.read_bytes() == b"earlier rejects"
    _no_temporaries(folder)


def test_a_full_disk_in_the_rejected_laz_file_leaves_both_earlier_files(
    survey: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    from kinsync.mount import Mount  # noqa: PLC0415
    from kinsync.pipelines.georef import georeference_file  # noqa: PLC0415

    folder = survey["dir"]
    out, rejected = folder / "geo.laz", folder / "geo.rejected.laz"
    out.write_bytes(b"earlier output")
    rejected.write_bytes(b"earlier rejects")
    _fill_disk_of(monkeypatch, "geo.rejected.laz")
    mount = Mount(lever_arm_body_m=(0.0, 0.0, 0.0))
    with pytest.raises(InputError, match=r"geo\.rejected\.laz: the disk is full"):
        georeference_file(survey["points"], survey["traj"], mount, out, outside="reject")
    assert out.read_bytes() == b"earlier output"
    assert rejected.read_bytes() == b"earlier rejects"
    _no_temporaries(folder)


@pytest.mark.parametrize("suffix", [".las", ".ply"])
def test_las_and_ply_outputs_on_a_full_disk_give_the_disk_full_line(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    survey: dict[str, Path],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
) -> None:
    """They said ``cannot write points ([Errno 28] ...)``, naming neither --out nor what to do."""
    out = survey["dir"] / f"geo{suffix}"
    _fill_disk_of(monkeypatch, out.name, room=4000)  # the header goes in, 300 points do not
    code, stdout, err = run_cli(_georef(survey, out, "--outside", "reject"))
    last = err.splitlines()[-1]
    assert_one_line_error(code, stdout, last + "\n", f"--out {out}", "disk is full", "free space")
    assert not out.exists()
    _no_temporaries(survey["dir"])


def test_an_sbet_on_a_full_disk_is_a_disk_full_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """numpy's tofile said ``29354 requested and 752 written``: an internal error."""
    t = 1.3e9 + np.arange(50) * 0.01
    z = 0.0 * t
    llh = np.column_stack([46.8 + z, -71.2 + z, 10.0 + z])
    _fill_disk_of(monkeypatch, "nav.sbet", room=1)
    with pytest.raises(InputError, match=r"nav\.sbet: the disk is full"):
        write_sbet(Trajectory.from_euler(t, z, z, z, lat_lon_h=llh), tmp_path / "nav.sbet")
    assert not (tmp_path / "nav.sbet").exists()
    _no_temporaries(tmp_path)


def test_a_laz_pass_file_on_a_full_disk_is_a_disk_full_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The simulations and the demo write passes through laspy + lazrs: it was a
    ``LazrsError`` (internal error, exit 1)."""
    rng = np.random.default_rng(0)
    p = SpherePass("p", 2.0, rng.normal(size=(200, 3)), t_s=np.arange(200.0))
    _fill_disk_of(monkeypatch, "pass_000.laz")
    with pytest.raises(InputError, match=r"pass_000\.laz: the disk is full"):
        write_passes(tmp_path / "passes", [p], file_format="laz")
    assert not (tmp_path / "passes" / "pass_000.laz").exists()


def test_the_second_of_two_outputs_on_a_full_disk_names_the_first(
    run_cli: RunCli,
    assert_one_line_error: OneLineError,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """As an interruption does: the model has replaced the earlier one, the user learns so."""
    logs = tmp_path / "logs"
    assert run_cli(["simulate", "clock", "--out", str(logs), "--duration-s", "60"])[0] == 0
    model, figure = tmp_path / "m.json", tmp_path / "f.png"
    real_write_bytes = Path.write_bytes

    def write_bytes(self: Path, data: Any) -> int:
        if self.name.startswith(".f.png."):
            raise _full()
        return real_write_bytes(self, data)

    monkeypatch.setattr(Path, "write_bytes", write_bytes)
    argv = ["clock", "fit", "--pps", str(logs / "pps.csv"), "--nmea", str(logs / "nmea.csv")]
    result = run_cli([*argv, "--model-out", str(model), "--figure", str(figure)])
    assert_one_line_error(
        *result, f"--figure {figure}: the disk is full", f"; written before it: {model}"
    )
    assert model.is_file()
    assert not figure.exists()


def test_a_full_disk_on_the_only_output_names_nothing_written_before(
    run_cli: RunCli, assert_one_line_error: OneLineError, tmp_path: Path
) -> None:
    """Outputs of earlier runs in the same process are not this run's."""
    logs = tmp_path / "logs"
    assert run_cli(["simulate", "clock", "--out", str(logs), "--duration-s", "60"])[0] == 0
    model = tmp_path / "m.json"

    def fail(*_: Any, **__: Any) -> int:
        raise _full()

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Path, "write_bytes", fail)
        argv = ["clock", "fit", "--pps", str(logs / "pps.csv"), "--nmea", str(logs / "nmea.csv")]
        code, stdout, err = run_cli([*argv, "--model-out", str(model)])
    assert_one_line_error(code, stdout, err, f"--model-out {model}: the disk is full")
    assert "written before it" not in err
