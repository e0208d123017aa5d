"""Scale-out of the georeferencing pipeline: process pool and Dask give the serial output."""

from __future__ import annotations

import math
import pickle
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import laspy
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from tests._georef_scan import (
    csv_points,
    nullable_points,
    scan_columns,
    write_laz,
    write_trajectory,
)

from kinsync.errors import InputError
from kinsync.io.las import las_end_times
from kinsync.io.points import TableChunkWriter
from kinsync.mount import Mount
from kinsync.pipelines.georef import georeference_file

MOUNT = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0))
N = 6_000
CHUNK = 700


@pytest.fixture(scope="module")
def dask_address() -> Iterator[str]:
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        yield str(cluster.scheduler_address)


@pytest.fixture(scope="module", params=["processes", "dask"])
def scheduler(request: pytest.FixtureRequest) -> str:
    if request.param == "dask":
        return str(request.getfixturevalue("dask_address"))
    return "processes"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("scale")
    write_trajectory(folder / "traj.csv", 10.0)
    cols = scan_columns(N, 10.0, seed=11)
    with TableChunkWriter(folder / "points.csv") as w:
        w.write(cols)
    write_laz(cols, folder / "points.laz")
    rng_p = np.random.default_rng(12)
    profile = {
        "t_s": cols["t_s"],
        "range_m": rng_p.uniform(2.0, 40.0, N),
        "angle_rad": rng_p.uniform(-np.pi, np.pi, N),
        "intensity": cols["intensity"],
    }
    pq.write_table(pa.table(profile), folder / "profile.parquet", row_group_size=500)
    cols["y_m"][4 * CHUNK + 3] = np.nan
    with TableChunkWriter(folder / "bad.csv") as w:
        w.write(cols)
    x_text = np.array([repr(float(v)) for v in cols["x_m"]], dtype=object)
    x_text[3003] = "x"  # in the 5th chunk (row groups of 700 rows)
    bad = pa.table(cols | {"x_m": x_text})
    pq.write_table(bad, folder / "bad.parquet", row_group_size=CHUNK)
    return {"dir": folder, "traj": folder / "traj.csv"}


def _run(inputs: dict[str, Path], name: str, out: str, **kw: object) -> Path:
    path = inputs["dir"] / out
    georeference_file(
        inputs["dir"] / name,
        inputs["traj"],
        MOUNT,
        path,
        chunk_points=CHUNK,
        outside="reject",
        **kw,  # type: ignore[arg-type]
    )
    return path


def test_csv_output_is_byte_identical(inputs: dict[str, Path], scheduler: str) -> None:
    serial = _run(inputs, "points.csv", "serial.csv", crs="EPSG:4979")
    reports: list[tuple[float, str]] = []
    scaled = _run(
        inputs,
        "points.csv",
        "scaled.csv",
        crs="EPSG:4979",
        scheduler=scheduler,
        workers=2,
        progress=lambda fraction, stage: reports.append((fraction, stage)),
    )
    before = [r for r in reports if r[1] != "georeferencing"]  # reading, checking: at 0
    assert before == [(0.0, s) for s in dict.fromkeys(s for _, s in before)]
    done = [f for f, stage in reports if stage == "georeferencing"]
    assert scaled.read_bytes() == serial.read_bytes()
    rej_serial = inputs["dir"] / "serial.rejected.csv"
    assert (inputs["dir"] / "scaled.rejected.csv").read_bytes() == rej_serial.read_bytes()
    assert done == sorted(done)
    assert done[0] == 0.0
    assert done[-1] == 1.0
    assert len(done) == 1 + math.ceil(N / CHUNK)  # the start, then each chunk


def test_laz_output_is_point_by_point_identical(
    inputs: dict[str, Path], scheduler: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    serial = laspy.read(_run(inputs, "points.laz", "serial.laz"))

    def no_reading_here(*_: object) -> None:
        raise AssertionError("the main process read points: the workers should")

    end_times_read: list[Path] = []

    def end_times(path: Path) -> tuple[float, float] | None:
        end_times_read.append(path)
        return las_end_times(path)

    with monkeypatch.context() as patch:  # the workers read their chunks by seek
        patch.setattr("kinsync.pipelines.georef_chunks.read_las_points", no_reading_here)
        patch.setattr("kinsync.pipelines.schedulers.LasPointReader", no_reading_here)
        patch.setattr("kinsync.pipelines.georef.las_end_times", end_times)
        scaled = laspy.read(_run(inputs, "points.laz", "scaled.laz", scheduler=scheduler))
    # the main process reads only the first and last point's time (for the offsets)
    assert end_times_read == [inputs["dir"] / "points.laz"]
    assert len(scaled.points) == len(serial.points) > 0
    for name in serial.point_format.dimension_names:
        np.testing.assert_array_equal(scaled[name], serial[name], err_msg=name)
    assert scaled.header.offsets.tolist() == serial.header.offsets.tolist()


def test_profile_parquet_output_is_identical_and_read_by_the_workers(
    inputs: dict[str, Path], scheduler: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    mount = replace(MOUNT, profiler_azimuth_deg=30.0)
    kw = {"chunk_points": CHUNK, "outside": "reject", "crs": "EPSG:4979"}
    folder = inputs["dir"]
    serial = folder / "profile_serial.parquet"
    summary = georeference_file(folder / "profile.parquet", inputs["traj"], mount, serial, **kw)  # type: ignore[arg-type]
    assert summary.points_rejected > 0
    scaled = folder / "profile_scaled.parquet"
    with monkeypatch.context() as patch:
        patch.setattr("kinsync.pipelines.georef_chunks.read_table_slice", lambda *_: 1 / 0)
        georeference_file(
            folder / "profile.parquet",
            inputs["traj"],
            mount,
            scaled,
            scheduler=scheduler,
            workers=2,
            **kw,  # type: ignore[arg-type]
        )
    assert pq.read_table(scaled).equals(pq.read_table(serial))
    rejected = pq.read_table(folder / "profile_scaled.rejected.parquet")
    assert rejected.equals(pq.read_table(folder / "profile_serial.rejected.parquet"))
    assert rejected.num_rows == summary.points_rejected


def test_carried_types_nulls_and_csv_rejected_lines_are_the_serial_ones(
    inputs: dict[str, Path], scheduler: str, tmp_path: Path
) -> None:
    """Workers send back a Parquet input's columns with their types and nulls, and a
    CSV's rejected rows as its own lines."""
    folder = inputs["dir"]
    table = nullable_points(1_500, 10.0, seed=13)
    pq.write_table(table, folder / "nulls.parquet", row_group_size=300)
    for suffix in (".parquet", ".csv"):
        _run(inputs, "nulls.parquet", f"nulls_serial{suffix}", crs="EPSG:4979")
        scaled = _run(
            inputs,
            "nulls.parquet",
            f"nulls_scaled{suffix}",
            crs="EPSG:4979",
            scheduler=scheduler,
            workers=2,
        )
        for name in (scaled.name, scaled.name.replace(".", ".rejected.")):
            got, want = folder / name, folder / name.replace("scaled", "serial")
            if suffix == ".csv":
                assert got.read_bytes() == want.read_bytes(), name
                continue
            got_table = pq.read_table(got)
            assert got_table.equals(pq.read_table(want)), name
            rows = pa.array(got_table.column("id").to_numpy())
            kept = [n for n in table.column_names if n in got_table.column_names]
            assert len(kept) >= len(table.column_names) - 3  # x_m,y_m,z_m became X,Y,Z
            assert got_table.select(kept).equals(table.take(rows).select(kept)), name
    src, header, lines = csv_points(tmp_path)
    georeference_file(
        src,
        inputs["traj"],
        MOUNT,
        tmp_path / "geo.csv",
        chunk_points=7,
        outside="reject",
        scheduler=scheduler,
        workers=2,
    )
    assert (tmp_path / "geo.rejected.csv").read_bytes() == header + b"".join(lines)


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("bad.csv", "bad.csv: line 2805, column 'y_m': nan is not finite"),
        ("bad.parquet", "bad.parquet: row 3004 of 6000, column 'x_m': 'x' is not"),  # read error
    ],
)
def test_worker_error_is_the_serial_error(
    inputs: dict[str, Path], scheduler: str, name: str, fragment: str
) -> None:
    out = name.replace("bad", "bad_out")
    with pytest.raises(InputError) as serial:
        _run(inputs, name, f"serial_{out}")
    with pytest.raises(InputError) as scaled:
        _run(inputs, name, f"scaled_{out}", scheduler=scheduler, workers=2)
    assert str(scaled.value) == str(serial.value)
    assert fragment in str(serial.value)
    assert not (inputs["dir"] / f"scaled_{out}").exists()


@pytest.mark.parametrize(
    ("scheduler_arg", "match"),
    [("threads", "--scheduler must be local, processes or tcp://"), ("processes", "--workers")],
)
def test_bad_scheduler_options(inputs: dict[str, Path], scheduler_arg: str, match: str) -> None:
    workers = 0 if scheduler_arg == "processes" else None
    with pytest.raises(InputError, match=match):
        _run(inputs, "points.csv", "x.csv", scheduler=scheduler_arg, workers=workers)


def test_pool_workers_read_the_context_from_a_file_not_from_their_arguments(
    inputs: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The main process writes a new worker's arguments into a pipe and waits until the
    # worker, after its imports, has read them: the context (megabytes with the prepared
    # trajectory) as an argument held the main process about a second per worker
    # started, one after another, so that 16 workers ran slower than 2.
    from kinsync.pipelines import schedulers  # noqa: PLC0415

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    runners: list[schedulers.ProcessRunner] = []
    seen: list[bool] = []
    start = schedulers.ProcessRunner.__init__
    submit = schedulers.ProcessRunner.submit

    def spy_init(self: schedulers.ProcessRunner, *args: Any) -> None:
        start(self, *args)
        runners.append(self)

    def spy_submit(self: schedulers.ProcessRunner, *args: Any) -> schedulers.ChunkResult:
        seen.append(self.context_path.is_file())
        return submit(self, *args)

    monkeypatch.setattr(schedulers.ProcessRunner, "__init__", spy_init)
    monkeypatch.setattr(schedulers.ProcessRunner, "submit", spy_submit)
    out = tmp_path / "out.csv"
    serial = tmp_path / "serial.csv"
    kwargs: dict[str, Any] = {"chunk_points": CHUNK, "outside": "reject"}
    georeference_file(inputs["dir"] / "points.csv", inputs["traj"], MOUNT, serial, **kwargs)
    georeference_file(
        inputs["dir"] / "points.csv",
        inputs["traj"],
        MOUNT,
        out,
        scheduler="processes",
        workers=2,
        **kwargs,
    )
    assert out.read_bytes() == serial.read_bytes()
    (runner,) = runners
    context_bytes = len(pickle.dumps(runner.ctx))
    arguments_bytes = len(pickle.dumps(runner.pool._initargs))
    assert context_bytes > 50_000  # the trajectory's records (prepared per chunk there)
    assert arguments_bytes < 1_000
    assert runner.context_path.parent == tmp_path
    assert runner.context_path.name.startswith("kinsync-context-")
    assert seen
    assert all(seen)  # there while the workers start...
    assert not runner.context_path.exists()  # ...and removed with the pool


def test_pool_starts_under_a_temporary_folder_too_deep_for_a_fork_server(
    inputs: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The fork server's Unix socket path (~107 bytes at most) does not fit under a deep
    # TMPDIR: the pool failed with "internal error: OSError: AF_UNIX path too long".
    # Run in a subprocess: a fork server already running in this one would be used.
    deep = tmp_path / ("d" * 60) / ("e" * 60)
    deep.mkdir(parents=True)
    monkeypatch.setenv("TMPDIR", str(deep))
    serial = _run(inputs, "points.csv", "deep_serial.csv")
    out = inputs["dir"] / "deep_pool.csv"
    code = (
        "import sys; from pathlib import Path; from kinsync.mount import Mount; "
        "from kinsync.pipelines.georef import georeference_file; "
        "m = Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0)); "
        "georeference_file(Path(sys.argv[1]), Path(sys.argv[2]), m, Path(sys.argv[3]), "
        f"chunk_points={CHUNK}, outside='reject', scheduler='processes', workers=2)"
    )
    args = [str(inputs["dir"] / "points.csv"), str(inputs["traj"]), str(out)]
    cmd = [sys.executable, "-c", code, *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert out.read_bytes() == serial.read_bytes()
    assert list(deep.glob("kinsync-*")) == []


def test_a_full_temporary_folder_is_an_error_naming_it_and_leaves_nothing(
    inputs: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:

    def full(*_args: object, **_kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(pickle, "dump", full)  # the pool pickles its context with it
    out = tmp_path / "out.csv"
    with pytest.raises(InputError, match=r"No space left on device.*TMPDIR.*--scheduler local"):
        _run(inputs, "points.csv", str(out), scheduler="processes", workers=2)
    assert not out.exists()
    assert list(tmp_path.glob("kinsync-*")) == []
