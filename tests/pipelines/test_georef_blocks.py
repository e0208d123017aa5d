"""The serial run's block threads: the same output and errors as one thread, blocks shared."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from tests._georef_scan import scan_columns, write_laz, write_trajectory

from kinsync.errors import InputError
from kinsync.io.points import TableChunkWriter
from kinsync.mount import Mount
from kinsync.pipelines import georef_chunks, schedulers
from kinsync.pipelines.georef import georeference_file, rejected_path_for

MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N = 300_000  # a chunk of 4.6 blocks of 65,536 points
BAD_ROW = 200_000  # in the 4th block


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("blocks")
    write_trajectory(folder / "traj.csv", 20.0)
    cols = scan_columns(N, 20.0, seed=5)
    with TableChunkWriter(folder / "points.parquet") as w:
        w.write(cols)
    write_laz(cols, folder / "points.laz")
    cols["y_m"][BAD_ROW] = np.inf
    with TableChunkWriter(folder / "bad.parquet") as w:
        w.write(cols)
    return folder


def _threads(monkeypatch: pytest.MonkeyPatch, n: int) -> list[int]:
    """Run the serial runner with ``n`` block threads; the threads that georeference.

    With several threads the first two blocks wait for each other (a barrier), so they
    must run at once on two threads: on a loaded machine one pool thread could
    otherwise take every block in turn, and a shared pool could not be told from that.
    A runner that ran its blocks one after the other would break the barrier (timeout).
    """
    monkeypatch.setattr(schedulers, "usable_cpus", lambda: n)
    seen: list[int] = []
    original = getattr(georef_chunks, "georeference")  # noqa: B009 - not exported
    meet = threading.Barrier(2, timeout=60.0)
    lock = threading.Lock()

    def spy(*args: Any, **kwargs: Any) -> Any:
        with lock:
            seen.append(threading.get_ident())
            first_two = len(seen) <= 2
        if n > 1 and first_two:
            meet.wait()
        return original(*args, **kwargs)

    monkeypatch.setattr(georef_chunks, "georeference", spy)
    return seen


def _run(folder: Path, name: str, out: str, **kw: Any) -> Path:
    path = folder / out
    georeference_file(
        folder / name,
        folder / "traj.csv",
        MOUNT,
        path,
        crs="EPSG:32619",
        chunk_points=N,
        outside="reject",
        **kw,
    )
    return path


@pytest.mark.parametrize(
    ("name", "out"),
    [("points.laz", "laz"), ("points.laz", "csv"), ("points.parquet", "parquet")],
)
def test_block_threads_write_what_one_thread_writes(
    inputs: Path, monkeypatch: pytest.MonkeyPatch, name: str, out: str
) -> None:
    with monkeypatch.context() as m:
        one = _threads(m, 1)
        single = _run(inputs, name, f"one_{name}.{out}")
    four = _threads(monkeypatch, 4)
    shared = _run(inputs, name, f"four_{name}.{out}")
    assert len(set(one)) == 1
    assert len(set(four)) > 1  # the blocks were shared among threads
    assert shared.read_bytes() == single.read_bytes()
    rejected = [rejected_path_for(path, inputs / name) for path in (single, shared)]
    assert rejected[0].stat().st_size > 0
    assert rejected[1].read_bytes() == rejected[0].read_bytes()


def test_block_threads_report_the_first_bad_point_as_one_thread_does(
    inputs: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    messages = []
    for n in (1, 4):
        with monkeypatch.context() as m:
            _threads(m, n)
            with pytest.raises(InputError) as err:
                _run(inputs, "bad.parquet", f"bad_{n}.parquet")
            messages.append(str(err.value))
    assert messages[0] == messages[1]
    assert f"bad.parquet: row {BAD_ROW + 1} of {N}, column 'y_m': inf is not finite" in messages[0]
