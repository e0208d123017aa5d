"""Interrupted runs leave nothing: SIGTERM and SIGINT exit 128+signal with no output and no
temporary; after SIGKILL no child process survives and the next run removes the stale
temporary. The commands run in a subprocess, as a user runs them."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import psutil
import pytest

from kinsync.io.points import TableChunkWriter
from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

T0 = 1.3e9
N_POINTS = 1_500_000
KINSYNC = [sys.executable, "-c", "from kinsync.cli import main; main()"]


@pytest.fixture(scope="module")
def survey(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A trajectory, a mount and a point file big enough to take seconds to georeference."""
    folder = tmp_path_factory.mktemp("interrupt")
    t = T0 + np.arange(0.0, 60.0, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.01 * s])
    traj = Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(s), 0.3 + 0.0 * s, lat_lon_h=llh
    )
    write_trajectory_csv(traj, folder / "traj.csv")
    rng = np.random.default_rng(3)
    with TableChunkWriter(folder / "points.parquet") as w:
        for i in range(0, N_POINTS, 250_000):
            n = min(250_000, N_POINTS - i)
            w.write(
                {
                    "t_s": T0 + np.sort(rng.uniform(0.0, 59.0, n)),
                    "x_m": rng.uniform(-1, 1, n),
                    "y_m": rng.uniform(-20, 20, n),
                    "z_m": rng.uniform(-5, 5, n),
                }
            )
    (folder / "mount.toml").write_text(
        "[mount]\nlever_arm_body_m = [0.5, 0.1, -1.0]\nboresight_rpy_deg = [0.5, -0.3, 90.0]\n"
        "latency_s = 0.0\n"
    )
    return folder


def _georef(survey: Path, out: Path, *extra: str) -> list[str]:
    return [
        *KINSYNC, "georef", "--points", str(survey / "points.parquet"),
        "--trajectory", str(survey / "traj.csv"), "--mount", str(survey / "mount.toml"),
        "--out", str(out), "--chunk-points", "20000", *extra,
    ]  # fmt: skip


def _temporaries(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.part"))


def _size(path: Path) -> int:
    """Size of a temporary, 0 once it is gone (the output-folder probe's empty file
    lives for microseconds: listed, then removed before it can be measured)."""
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


@pytest.fixture
def temp(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A temporary folder of the commands' own (TMPDIR), to see what they leave there.

    Short (in the system's temporary folder, not pytest's deep one), so that the pool
    starts its workers from a fork server, as it does for most users.
    """
    folder = Path(tempfile.mkdtemp(prefix="ks-"))
    monkeypatch.setenv("TMPDIR", str(folder))
    yield folder
    shutil.rmtree(folder)


def _start_and_wait_for_part(
    cmd: list[str], folder: Path
) -> tuple[subprocess.Popen[str], list[psutil.Process]]:
    """Start ``cmd``; return once its temporary output has data (it is mid-write)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120.0
    while not any(_size(p) for p in _temporaries(folder)):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no temporary output appeared"
        time.sleep(0.01)
    time.sleep(0.2)
    children = psutil.Process(proc.pid).children(recursive=True)
    return proc, children


def _assert_all_gone(procs: list[psutil.Process], timeout_s: float = 10.0) -> None:
    _, alive = psutil.wait_procs(procs, timeout=timeout_s)
    assert not alive, [p.as_dict(attrs=["pid", "name", "cmdline"]) for p in alive]


def _workers(scheduler: str, n: int) -> tuple[str, ...]:
    """``--workers n`` where the scheduler uses it (local refuses it)."""
    return () if scheduler == "local" else ("--workers", str(n))


@pytest.mark.parametrize("scheduler", ["local", "processes"])
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_stop_signal_leaves_nothing(
    survey: Path,
    tmp_path: Path,
    scheduler: str,
    signum: signal.Signals,
    temp: Path,
) -> None:
    out = tmp_path / "out.csv"
    proc, children = _start_and_wait_for_part(
        _georef(survey, out, "--scheduler", scheduler, *_workers(scheduler, 2)), tmp_path
    )
    assert scheduler == "local" or children, "the pool has no worker"
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err
    assert err.strip().splitlines()[-1] == (
        f"kinsync: interrupted by {signum.name}; unfinished outputs removed"
    ), err
    assert "Traceback" not in err
    assert not out.exists()
    assert _temporaries(tmp_path) == []
    _assert_all_gone(children)
    assert list(temp.iterdir()) == []  # the pool's context file too


def test_sigkill_leaves_no_process_and_the_next_run_cleans_up(
    survey: Path, tmp_path: Path, temp: Path
) -> None:
    out = tmp_path / "out.csv"
    cmd = _georef(survey, out, "--scheduler", "processes", "--workers", "2")
    proc, children = _start_and_wait_for_part(cmd, tmp_path)
    assert children
    stale = _temporaries(tmp_path)
    proc.kill()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    _assert_all_gone(children)  # forkserver, resource tracker and workers
    # The workers removed the pool's context file (Python's own forkserver folder,
    # pymp-*, with its socket, is left: only the forkserver could remove it).
    assert list(temp.glob("kinsync-*")) == []
    assert "Traceback" not in err
    assert _temporaries(tmp_path) == stale  # SIGKILL cannot be caught: the debris stays...
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert out.exists()
    assert _temporaries(tmp_path) == []  # ...until the same output is written next


def test_ins_run_sigterm_leaves_nothing(tmp_path: Path) -> None:
    sim = tmp_path / "drive"
    subprocess.run(
        [*KINSYNC, "simulate", "drive", "--out", str(sim), "--duration-s", "1500"],
        check=True, capture_output=True,
    )  # fmt: skip
    out = tmp_path / "nav.csv"
    cmd = [
        *KINSYNC, "ins", "run", "--imu", str(sim / "imu.csv"), "--gnss", str(sim / "gnss.csv"),
        "--config", str(sim / "ins.toml"), "--out", str(out), "--smooth",
    ]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.5)  # reading or filtering
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive"]


def test_stale_temporaries_of_live_processes_and_other_outputs_are_kept(tmp_path: Path) -> None:
    from kinsync.io.atomic import atomic_write_text  # noqa: PLC0415

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".a.csv.{dead.pid}.abcd1234.part"
    live = tmp_path / f".a.csv.{os.getpid()}.abcd1234.part"
    other = tmp_path / f".b.csv.{dead.pid}.abcd1234.part"
    for p in (stale, live, other):
        p.write_text("x")
    atomic_write_text(tmp_path / "a.csv", "t\n")
    assert not stale.exists()
    assert live.exists()
    assert other.exists()


def test_another_containers_temporary_is_kept_until_a_day_old(tmp_path: Path) -> None:
    """Review Q4: a writer in another PID namespace (a container sharing the volume, an
    NFS host) has a pid this process cannot see: its live temporary was removed."""
    from kinsync.io.atomic import FOREIGN_STALE_S, atomic_write_text, writer_tag  # noqa: PLC0415

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    foreign_tag = "0" * 8 if writer_tag() != "0" * 8 else "1" * 8
    ours = tmp_path / f".a.csv.{dead.pid}.abcd1234.h{writer_tag()}.part"
    theirs = tmp_path / f".a.csv.{dead.pid}.abcd1235.h{foreign_tag}.part"
    old = tmp_path / f".a.csv.{dead.pid}.abcd1236.h{foreign_tag}.part"
    for p in (ours, theirs, old):
        p.write_text("x")
    a_day_ago = time.time() - FOREIGN_STALE_S - 60.0
    os.utime(old, (a_day_ago, a_day_ago))
    atomic_write_text(tmp_path / "a.csv", "t\n")
    assert not ours.exists()  # this machine's, its writer gone
    assert theirs.exists()  # another's: its writer may be alive there
    assert not old.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part") and p not in (theirs,)]


def _maps_numpy(pid: int) -> bool:
    """True once the process has loaded numpy's extension (its heavy imports began)."""
    try:
        return "_multiarray_umath" in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc")
def test_ctrl_c_during_the_imports_exits_130_in_one_line(tmp_path: Path) -> None:
    # The program's imports (numpy, every command module) take most of a second; a
    # Ctrl-C then once printed a Python traceback.
    out = tmp_path / "demo"
    cmd = [sys.executable, "-m", "kinsync", "demo", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60.0
    while not _maps_numpy(proc.pid):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "numpy was never loaded"
        time.sleep(0.001)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.splitlines() == ["kinsync: interrupted by SIGINT; unfinished outputs removed"]
    assert not out.exists()
