"""An output beyond the largest file allowed (EFBIG): one line naming it, exit 2.

A file-size limit (``ulimit -f``) or a file system's largest file (FAT32's 4 GiB) ended
a CSV output as ``internal error: OSError: [Errno 27] File too large`` (exit 1), and a
LAZ output as ``c.laz: cannot write (File too large)``, without its option or what to
do. The limit is set here for real, in a child process (``RLIMIT_FSIZE``; Python
ignores the SIGXFSZ that would otherwise end it), as a full disk is simulated in
``test_disk_full.py``.
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest
from tests._georef_scan import scan_columns, write_laz, write_trajectory

from kinsync.errors import DiskFullError
from kinsync.io.atomic import atomic_path

resource = pytest.importorskip("resource")  # not on Windows

LIMIT_BYTES = 8192


def _limited(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT_BYTES, LIMIT_BYTES))

    return subprocess.run(
        [sys.executable, "-m", "kinsync", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        preexec_fn=limit,
    )


@pytest.fixture(scope="module")
def survey(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("survey")
    write_trajectory(folder / "traj.csv", 4.0)
    cols = scan_columns(2000, 3.0, 1)
    cols["t_s"] = cols["t_s"] + 0.6  # every point inside the trajectory: no rejects file
    write_laz(cols, folder / "scan.laz")
    (folder / "m.toml").write_text("[mount]\nlever_arm_body_m = [0, 0, 0]\nlatency_s = 0.0\n")
    return folder


@pytest.mark.parametrize("suffix", [".csv", ".laz"])
def test_an_output_beyond_the_file_size_limit_is_named_with_what_to_do(
    survey: Path, suffix: str
) -> None:
    out = f"geo{suffix}"
    args = ["georef", "--points", "scan.laz", "--trajectory", "traj.csv", "--mount", "m.toml"]
    proc = _limited(*args, "--out", out, cwd=survey)
    last = proc.stderr.splitlines()[-1] if proc.stderr else ""
    assert proc.returncode == 2, proc.stderr
    assert last.startswith(f"kinsync: error: --out {out}: "), proc.stderr
    assert "ulimit -f" in last
    assert "another file system" in last
    assert "Traceback" not in proc.stderr
    assert not (survey / out).exists()
    assert not [p.name for p in survey.iterdir() if p.name.endswith(".part")]


def test_atomic_path_turns_efbig_into_a_disk_full_error(tmp_path: Path) -> None:
    out = tmp_path / "o.csv"
    with pytest.raises(DiskFullError, match=r"o\.csv: the file has grown beyond"), atomic_path(out):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))
    assert list(tmp_path.iterdir()) == []
