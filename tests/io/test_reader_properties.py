"""Every reader, driven through the command that reads its file kind, on hostile files.

Property (issue 15, "Done when"): arbitrary bytes, truncations, absurd numbers and
duplicated or reordered rows give exit 2 with one line on stderr (``kinsync: error:``),
or exit 0 with every number of the outputs finite; never exit 1, a traceback, a hang
past a bound or a non-finite number in an output.

A valid set of small inputs is made once with the simulators (``kinsync simulate ...``
and the writers of `kinsync.io`); each example mutates one file of it and runs the CLI
in-process (``kinsync.cli.main``), the way a user does. Mutations: the whole file
replaced by arbitrary bytes, a truncation at any byte, bytes inserted or overwritten,
a number (or a comma-separated field) replaced by an absurd value (1e308, nan, inf,
2**70, '', a negative value, a huge string, ...), a whole column set to one absurd
value, lines or records duplicated, swapped or deleted; for Parquet also cells,
column types and rows of the table itself.

``KINSYNC_PROPERTY_EXAMPLES`` scales the number of examples (default: a few per
reader, the whole module in well under a minute).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import signal
import tempfile
import tracemalloc
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any, Literal

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kinsync.cli import main
from kinsync.io.cidco import ACQUISITION_MOUNT
from kinsync.io.mount_file import read_mount, write_mount
from kinsync.io.points import TableChunkWriter
from kinsync.io.sbet import SBET_RECORD_BYTES, write_sbet
from kinsync.io.smrmsg import SMRMSG_RECORD_BYTES, SmrmsgData, write_smrmsg
from kinsync.io.trajectory_csv import read_trajectory_csv
from kinsync.mount import Mount
from kinsync.sync.clock_mount import ClockMount

pytestmark = pytest.mark.slow

CIDCO = Path(__file__).resolve().parents[3] / "shared" / "data" / "cidco-port-de-quebec" / "sphere1"
EXAMPLES = float(os.environ.get("KINSYNC_PROPERTY_EXAMPLES", "1"))
HANG_S = 60
"""Hard bound of one run (s): far above the ~0.1 s a run of these small files takes."""

Base = dict[str, Path]


# --------------------------------------------------------------------------- running
class _Hang(BaseException):
    """Raised by the alarm in a run that passed `HANG_S` (not caught by ``main``)."""


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    del signum, frame
    raise _Hang


@dataclass(frozen=True)
class Outcome:
    code: int
    out: str
    err: str
    warned: tuple[str, ...]


def run(argv: list[str]) -> Outcome:
    """``kinsync ARGV`` in-process: exit status, stdout, stderr and Python warnings."""
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(HANG_S)
    try:
        with (
            warnings.catch_warnings(record=True) as caught,
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            warnings.simplefilter("always")
            try:
                main([str(a) for a in argv])
                code = 0
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 0
    except _Hang:
        pytest.fail(f"kinsync {' '.join(map(str, argv))} ran past {HANG_S} s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    warned = tuple(f"{w.category.__name__}: {w.message}" for w in caught)
    return Outcome(code, out.getvalue(), err.getvalue(), warned)


# --------------------------------------------------------------------------- inputs
def _sim(args: list[str]) -> None:
    outcome = run(["simulate", *args, "--json"])
    assert outcome.code == 0, outcome.err


def make_inputs(d: Path) -> Base:
    """A small valid input of every kind in ``d``, made with the simulators and writers."""
    _sim(
        [
            "drive",
            "--out",
            str(d / "drive"),
            "--duration-s",
            "8",
            "--static-s",
            "3",
            "--imu",
            "mems",
            "--imu-rate-hz",
            "20",
            "--gnss-rate-hz",
            "1",
        ]
    )
    _sim(["clock", "--out", str(d / "clock"), "--duration-s", "12"])
    _sim(
        ["rotating-table", "--out", str(d / "rt"), "--rates-deg-s", "10", "--passes", "1", "--raw"]
    )
    _sim(["drive-scan", "--out", str(d / "ds"), "--near-targets-only", "--extra-first-pulse"])
    drive, ds = d / "drive", d / "ds"
    truth = read_trajectory_csv(drive / "truth.csv")
    write_sbet(truth, d / "traj.sbet")
    n = 9
    write_smrmsg(
        SmrmsgData(
            t_s=np.arange(n, dtype=np.float64),
            std_pos_ned_m=np.full((n, 3), 0.02),
            std_vel_ned_m_s=np.full((n, 3), 0.01),
            std_rpy_rad=np.full((n, 3), 1e-4),
        ),
        d / "smrmsg_traj.out",
    )
    write_mount(
        Mount(lever_arm_body_m=(0.5, 0.1, -1.0), boresight_rpy_deg=(0.5, -0.3, 90.0)),
        d / "mount.toml",
    )
    write_mount(ACQUISITION_MOUNT, d / "acquisition.toml")
    rng = np.random.default_rng(1)
    k = 30
    points = {
        "t_s": np.sort(rng.uniform(0.5, 7.5, k)),
        "x_m": rng.uniform(-1, 1, k),
        "y_m": rng.uniform(-20, 20, k),
        "z_m": rng.uniform(-5, 5, k),
        "intensity": rng.integers(0, 1000, k),
    }
    for suffix in ("csv", "parquet"):
        with TableChunkWriter(d / f"points.{suffix}") as writer:
            writer.write(points)
    with (ds / "scan.csv").open() as fh:  # the first profiles only: a small scan
        (d / "scan.csv").write_text("".join(next(fh) for _ in range(120)))
    # as sync object-space --json writes it: with the mount it was fitted with
    fitted_with = ClockMount.of(read_mount(ds / "mount.toml"), str(ds / "mount.toml"))
    clock = {"t0_s": 1400000000.43, "period_s": 0.0305, "mount": fitted_with.as_document()}
    (d / "clock.json").write_text(json.dumps(clock))
    files: Base = {
        "dir": d,
        "truth": drive / "truth.csv",
        "imu": drive / "imu.csv",
        "gnss": drive / "gnss.csv",
        "ins_config": drive / "ins.toml",
        "sbet": d / "traj.sbet",
        "smrmsg": d / "smrmsg_traj.out",
        "pps": d / "clock" / "pps.csv",
        "nmea": d / "clock" / "nmea.csv",
        "mount": d / "mount.toml",
        "acquisition_mount": d / "acquisition.toml",
        "points_csv": d / "points.csv",
        "points_parquet": d / "points.parquet",
        "rt": d / "rt",
        "ds": ds,
        "scan": d / "scan.csv",
        "clock_document": d / "clock.json",
        "model": d / "model.json",
        "solution": d / "solution.csv",
        "cidco": CIDCO / "passage_5.txt",
    }
    outcome = run(_ins_args(files, "--out", d / "solution.csv"))
    assert outcome.code == 0, outcome.err
    outcome = run(_clock_fit_args(files, "--model-out", d / "model.json"))
    assert outcome.code == 0, outcome.err
    return files


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Base:
    return make_inputs(tmp_path_factory.mktemp("reader-properties"))


# --------------------------------------------------------------------------- commands
def _ins_args(b: Base, *extra: object, **files: Path) -> list[str]:
    return [
        "ins",
        "run",
        "--imu",
        str(files.get("imu", b["imu"])),
        "--gnss",
        str(files.get("gnss", b["gnss"])),
        "--config",
        str(files.get("ins_config", b["ins_config"])),
        "--init-from",
        str(files.get("truth", b["truth"])),
        "--json",
        *map(str, extra),
    ]


def _clock_fit_args(b: Base, *extra: object, **files: Path) -> list[str]:
    pps, nmea = files.get("pps", b["pps"]), files.get("nmea", b["nmea"])
    return ["clock", "fit", "--pps", str(pps), "--nmea", str(nmea), "--json", *map(str, extra)]


Argv = Callable[[Base, Path, Path], list[str]]
"""(inputs, the mutated file, a work folder) -> the command line."""


def _georef(suffix: str) -> Argv:
    def argv(b: Base, f: Path, w: Path) -> list[str]:
        return [
            "georef",
            "--points",
            str(f),
            "--trajectory",
            str(b["truth"]),
            "--mount",
            str(b["mount"]),
            "--out",
            str(w / f"out.{suffix}"),
            "--json",
        ]

    return argv


def _object_space(key: str) -> Argv:
    def argv(b: Base, f: Path, w: Path) -> list[str]:
        del w
        ds = b["ds"]
        files = {
            "scan": ds / "scan.csv",
            "trajectory": ds / "trajectory.csv",
            "sync-points": ds / "sync_points.csv",
            "pulses": ds / "pulses.csv",
        }
        files[key] = f
        opts = [x for k, v in files.items() for x in (f"--{k}", str(v))]
        return ["sync", "object-space", *opts, "--mount", str(ds / "mount.toml"), "--json"]

    return argv


def _sync_apply(b: Base, scan: Path, clock: Path, w: Path) -> list[str]:
    return [
        "sync",
        "apply",
        "--scan",
        str(scan),
        "--mount",
        str(b["ds"] / "mount.toml"),
        "--clock",
        str(clock),
        "--out",
        str(w / "scan_t.csv"),
        "--json",
    ]


def _calibrate(b: Base, f: Path, w: Path) -> list[str]:
    del w
    return [
        "calibrate",
        "mount",
        "--points",
        str(f),
        "--points",
        str(CIDCO / "passage_6.txt"),
        "--mount",
        str(b["acquisition_mount"]),
        "--features",
        "spheres",
        "--sphere-radius-m",
        "0.2",
        "--estimate",
        "latency",
        "--json",
    ]


def _latency(*extra: str) -> Argv:
    def argv(b: Base, f: Path, w: Path) -> list[str]:
        del b, f
        return ["latency", "sphere", str(w / "rt"), "--no-figure", "--json", *extra]

    return argv


@dataclass(frozen=True)
class Case:
    """One reader, the file it reads and the command that reads it.

    Attributes
    ----------
    name : str
        Test id (the reader).
    target : str
        Key in the inputs of the file mutated; with ``folder``, its path in the folder.
    argv : Argv
        The command line.
    kind : {"text", "records", "parquet"}
        How the file is mutated.
    record_bytes : int
        Record length of a binary record file.
    folder : str or None
        Key of a folder copied (as links) into the work folder, ``target`` replaced.
    outputs : tuple of (str, tuple of str)
        Output files in the work folder and their columns that must be finite (all
        numeric columns when empty).
    examples : int
        Hypothesis examples (scaled by ``KINSYNC_PROPERTY_EXAMPLES``).
    """

    name: str
    target: str
    argv: Argv
    kind: Literal["text", "records", "parquet"] = "text"
    record_bytes: int = 0
    folder: str | None = None
    outputs: tuple[tuple[str, tuple[str, ...]], ...] = ()
    examples: int = 12


CASES = (
    Case("trajectory_csv", "truth", lambda _b, f, _w: ["trajectory", "info", str(f), "--json"]),
    Case(
        "sbet",
        "sbet",
        lambda _b, f, _w: ["trajectory", "info", str(f), "--json"],
        kind="records",
        record_bytes=SBET_RECORD_BYTES,
    ),
    Case(
        "smrmsg",
        "smrmsg",
        lambda b, f, _w: ["trajectory", "info", str(b["sbet"]), "--smrmsg", str(f), "--json"],
        kind="records",
        record_bytes=SMRMSG_RECORD_BYTES,
    ),
    Case(
        "nav_csv",
        "solution",
        lambda b, f, _w: ["ins", "compare", str(f), str(b["truth"]), "--json"],
    ),
    Case(
        "imu_csv",
        "imu",
        lambda b, f, w: _ins_args(b, "--out", w / "sol.csv", imu=f),
        outputs=(("sol.csv", ()),),
    ),
    Case(
        "gnss_csv",
        "gnss",
        lambda b, f, w: _ins_args(b, "--out", w / "sol.csv", gnss=f),
        outputs=(("sol.csv", ()),),
    ),
    Case(
        "ins_config",
        "ins_config",
        lambda b, f, w: _ins_args(b, "--out", w / "sol.csv", ins_config=f),
        outputs=(("sol.csv", ()),),
    ),
    Case(
        "trajectory_csv_init",
        "truth",
        lambda b, f, w: _ins_args(b, "--out", w / "sol.csv", truth=f),
        outputs=(("sol.csv", ()),),
    ),
    Case(
        "nmea_log",
        "nmea",
        lambda b, f, w: _clock_fit_args(b, "--model-out", w / "m.json", nmea=f),
        outputs=(("m.json", ()),),
    ),
    Case(
        "pps_csv",
        "pps",
        lambda b, f, w: _clock_fit_args(b, "--model-out", w / "m.json", pps=f),
        outputs=(("m.json", ()),),
    ),
    Case(
        "clock_model",
        "model",
        lambda b, f, w: (
            [
                "clock",
                "apply",
                "--model",
                str(f),
                "--in",
                str(b["pps"]),
                "--out",
                str(w / "o.csv"),
                "--json",
            ]
        ),
        outputs=(("o.csv", ("t_gps_s",)),),
    ),
    Case(
        "time_column",
        "nmea",
        lambda b, f, w: (
            [
                "clock",
                "apply",
                "--model",
                str(b["model"]),
                "--in",
                str(f),
                "--out",
                str(w / "o.csv"),
                "--json",
            ]
        ),
        outputs=(("o.csv", ("t_gps_s",)),),
    ),
    Case(
        "points_csv",
        "points_csv",
        _georef("csv"),
        outputs=(("out.csv", ("X", "Y", "Z")),),
    ),
    Case(
        "points_parquet",
        "points_parquet",
        _georef("parquet"),
        kind="parquet",
        outputs=(("out.parquet", ("X", "Y", "Z")),),
    ),
    Case(
        "profile_scan",
        "scan",
        lambda b, f, w: _sync_apply(b, f, b["clock_document"], w),
        outputs=(("scan_t.csv", ("t_s", "x_m", "y_m", "z_m")),),
    ),
    Case(
        "clock_document",
        "clock_document",
        lambda b, f, w: _sync_apply(b, b["scan"], f, w),
        outputs=(("scan_t.csv", ("t_s", "x_m", "y_m", "z_m")),),
    ),
    Case("sync_points", "sync_points.csv", _object_space("sync-points"), folder="ds"),
    Case("pulses", "pulses.csv", _object_space("pulses"), folder="ds", examples=8),
    Case("pass_index", "passes.csv", _latency(), folder="rt"),
    Case("pass_file", "pass_000.csv", _latency(), folder="rt", examples=8),
    Case("raw_attitude", "raw/attitude.csv", _latency("--raw"), folder="rt", examples=8),
    Case("raw_pass", "raw/pass_000.csv", _latency("--raw"), folder="rt", examples=8),
    Case("cidco", "cidco", _calibrate, examples=8),
)


# --------------------------------------------------------------------------- mutations
ABSURD_TEXT = (
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "-1e309",
    "4.9e-324",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    str(2**70),
    str(-(2**70)),
    "",
    " ",
    "0",
    "-0",
    "-1",
    "-0.001",
    "1e-12",
    "9" * 400,
    "1." + "0" * 5000,
    "x" * 3000,
    '"',
    "1,2",
    "\x00",
    "١٢",
    "1_0",
    "0x10",
    "+",
    "e",
    "null",
    "true",
    "[]",
    "{}",
    '"text"',
    "[1, 2]",
)
ABSURD_FLOATS = (
    1e308,
    -1e308,
    float("inf"),
    float("-inf"),
    float("nan"),
    2.0**70,
    -(2.0**70),
    -1.0,
    0.0,
    5e-324,
    1e-300,
)
_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _absurd_text() -> st.SearchStrategy[bytes]:
    return st.one_of(
        st.sampled_from(ABSURD_TEXT).map(str.encode),
        st.floats().map(lambda v: repr(v).encode()),
        st.integers(min_value=-(2**80), max_value=2**80).map(lambda v: str(v).encode()),
    )


def _absurd_float() -> st.SearchStrategy[float]:
    return st.one_of(st.sampled_from(ABSURD_FLOATS), st.floats())


def _byte_mutation(draw: st.DrawFn, data: bytes) -> tuple[str, bytes]:
    op = draw(st.sampled_from(["arbitrary", "truncate", "insert", "overwrite"]))
    if op == "arbitrary":
        return op, draw(st.binary(max_size=4096))
    if op == "truncate":
        return op, data[: draw(st.integers(0, max(len(data) - 1, 0)))]
    k = draw(st.integers(0, len(data)))
    chunk = draw(st.binary(min_size=1, max_size=64))
    if op == "insert":
        return op, data[:k] + chunk + data[k:]
    return op, data[:k] + chunk + data[k + len(chunk) :]


def _split_lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def _text_mutation(draw: st.DrawFn, data: bytes) -> tuple[str, bytes]:
    op = draw(
        st.sampled_from(
            ["bytes", "number", "number", "field", "column", "duplicate", "swap", "delete"]
        )
    )
    if op == "bytes":
        return _byte_mutation(draw, data)
    lines = _split_lines(data)
    body = [i for i in range(1, len(lines)) if lines[i].strip()]
    if op == "number":
        spans = [m.span() for m in _NUMBER.finditer(data)]
        if spans:
            a, b = draw(st.sampled_from(spans))
            return op, data[:a] + draw(_absurd_text()) + data[b:]
        return op, data
    if op in ("field", "column"):
        sep = b"," if b"," in lines[0] else b" "
        width = max(len(ln.split(sep)) for ln in lines)
        j = draw(st.integers(0, width - 1))
        value = draw(_absurd_text())
        rows = [draw(st.integers(0, len(lines) - 1))] if op == "field" else body
        for i in rows:
            cells = lines[i].split(sep)
            if j < len(cells):
                cells[j] = value
                lines[i] = sep.join(cells)
        return f"{op} {j}", b"\n".join(lines)
    if not body:
        return op, data
    i, k = draw(st.sampled_from(body)), draw(st.sampled_from(body))
    if op == "duplicate":
        lines.insert(k, lines[i])
    elif op == "swap":
        lines[i], lines[k] = lines[k], lines[i]
    else:
        del lines[i]
    return f"{op} {i} {k}", b"\n".join(lines)


def _record_mutation(draw: st.DrawFn, data: bytes, size: int) -> tuple[str, bytes]:
    op = draw(st.sampled_from(["bytes", "field", "column", "duplicate", "swap", "delete"]))
    if op == "bytes":
        return _byte_mutation(draw, data)
    rec = np.frombuffer(data, dtype="<f8").reshape(-1, size // 8).copy()
    n, width = rec.shape
    i, k = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
    j = draw(st.integers(0, width - 1))
    if op == "field":
        rec[i, j] = draw(_absurd_float())
    elif op == "column":
        rec[:, j] = draw(_absurd_float())
    elif op == "duplicate":
        rec = np.insert(rec, k, rec[i], axis=0)
    elif op == "swap":
        rec[[i, k]] = rec[[k, i]]
    else:
        rec = np.delete(rec, i, axis=0)
    return f"{op} {i} {j} {k}", rec.tobytes()


def _parquet_mutation(draw: st.DrawFn, data: bytes) -> tuple[str, bytes]:
    op = draw(st.sampled_from(["bytes", "cell", "column", "strings", "drop", "rows"]))
    if op == "bytes":
        return _byte_mutation(draw, data)
    table = pq.read_table(pa.BufferReader(data))
    cols = {name: table.column(name).to_pylist() for name in table.column_names}
    name = draw(st.sampled_from(table.column_names))
    n = table.num_rows
    if op == "cell":
        cols[name][draw(st.integers(0, n - 1))] = draw(_absurd_float())
    elif op == "column":
        cols[name] = [draw(_absurd_float())] * n
    elif op == "strings":
        cols[name] = [draw(st.sampled_from(ABSURD_TEXT))] * n
    elif op == "drop":
        del cols[name]
    else:
        order = draw(st.lists(st.integers(0, n - 1), max_size=2 * n))
        cols = {k: [v[i] for i in order] for k, v in cols.items()}
    sink = io.BytesIO()
    pq.write_table(pa.table(cols), sink)
    return f"{op} {name}", sink.getvalue()


@dataclass(frozen=True)
class Mutated:
    """A mutated file: what was done and the bytes; its repr shows where it differs."""

    what: str
    data: bytes
    original: bytes

    def __repr__(self) -> str:
        a, b = self.original, self.data
        i = next((k for k in range(min(len(a), len(b))) if a[k] != b[k]), min(len(a), len(b)))
        j = 0  # common suffix, not reaching back over i
        while j < min(len(a), len(b)) - i and a[len(a) - 1 - j] == b[len(b) - 1 - j]:
            j += 1
        old, new = a[max(i - 30, 0) : len(a) - j + 30], b[max(i - 30, 0) : len(b) - j + 30]
        return (
            f"Mutated({self.what}: {len(a)} -> {len(b)} bytes, from byte {i}: "
            f"{old[:300]!r} -> {new[:300]!r})"
        )


@st.composite
def mutations(draw: st.DrawFn, case: Case, data: bytes) -> Mutated:
    """One mutation of a file."""
    if case.kind == "records":
        what, new = _record_mutation(draw, data, case.record_bytes)
    elif case.kind == "parquet":
        what, new = _parquet_mutation(draw, data)
    else:
        what, new = _text_mutation(draw, data)
    return Mutated(what, new, data)


# --------------------------------------------------------------------------- checks
def _reject_constant(name: str) -> Any:
    msg = f"non-finite {name} in the JSON output"
    raise AssertionError(msg)


def _walk(doc: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _walk(v, f"{path}.{k}")
    elif isinstance(doc, list):
        for v in doc:
            yield from _walk(v, f"{path}[]")
    else:
        yield path, doc


def _numeric_paths(doc: Any) -> tuple[set[str], set[str]]:
    """Paths of numbers and of nulls in a JSON document (list items as ``[]``)."""
    numbers, nulls = set(), set()
    for path, v in _walk(doc):
        if isinstance(v, int | float) and not isinstance(v, bool):
            numbers.add(path)
        elif v is None:
            nulls.add(path)
    return numbers, nulls


MAY_BE_NULL = {
    # None, documented, when the positions do not move at all (a file cut to its first,
    # stationary records: hypothesis found it in CI)
    ".velocity_check.velocity_scale",
}
"""Numbers that a valid, shorter input may turn into a documented null."""


def _check_json(out: str, baseline: Any) -> None:
    doc = json.loads(out, parse_constant=_reject_constant)
    for path, v in _walk(doc):
        assert not (isinstance(v, float) and not math.isfinite(v)), f"{path} = {v}"
    # print_json turns a non-finite float into null: a null where the valid input gave
    # a number is a non-finite result.
    numbers, nulls = _numeric_paths(baseline)
    _, now_null = _numeric_paths(doc)
    became_null = sorted((now_null & numbers) - nulls - MAY_BE_NULL)
    assert not became_null, f"null (non-finite) where a number is expected: {became_null}"


def _check_output_file(path: Path, columns: tuple[str, ...]) -> None:
    if path.suffix == ".json":
        doc = json.loads(path.read_text(), parse_constant=_reject_constant)
        for where, v in _walk(doc):
            assert not (isinstance(v, float) and not math.isfinite(v)), f"{path}{where} = {v}"
        return
    table = pq.read_table(path) if path.suffix == ".parquet" else pa_csv.read_csv(path)
    names = columns or tuple(
        n for n in table.column_names if pa.types.is_floating(table.column(n).type)
    )
    for name in names:
        values = np.asarray(table.column(name).to_numpy(zero_copy_only=False), dtype=np.float64)
        bad = np.flatnonzero(~np.isfinite(values))
        assert bad.size == 0, f"{path.name}: column {name!r} row {bad[0]}: {values[bad[0]]}"


PYTHON_REPRS = ("np.float64(", "np.int64(", "datetime.datetime(", "array(", "dtype=")
"""Python and numpy reprs that have no place in a message to a surveyor (class 6)."""


def check_outcome(case: Case, outcome: Outcome, work: Path, baseline: Any) -> None:
    """The property: exit 2 with one error line, or exit 0 with finite outputs."""
    text = f"exit {outcome.code}\nstderr: {outcome.err[-3000:]}\nwarnings: {outcome.warned}"
    runtime = [w for w in outcome.warned if w.startswith("RuntimeWarning")]
    assert not runtime, text
    if outcome.code == 2:
        assert outcome.out == "", text
        assert outcome.err.startswith("kinsync: error: "), text
        assert outcome.err.count("\n") == 1, text
        reprs = [r for r in PYTHON_REPRS if r in outcome.err]
        assert not reprs, text  # a message shows values as a user writes them
        return
    assert outcome.code == 0, text
    assert "Traceback" not in outcome.err, text
    _check_json(outcome.out, baseline)
    for name, columns in case.outputs:
        _check_output_file(work / name, columns)


# --------------------------------------------------------------------------- the test
def _target(b: Base, case: Case) -> Path:
    return b[case.folder] / case.target if case.folder else b[case.target]


def _work_copy(b: Base, case: Case, work: Path, data: bytes) -> Path:
    """Write the mutated file into ``work`` (with the rest of its folder, linked)."""
    if case.folder is None:
        path = work / _target(b, case).name
    else:
        src = b[case.folder]
        dst = work / src.name
        for p in src.rglob("*"):
            rel = p.relative_to(src)
            if p.is_dir():
                (dst / rel).mkdir(parents=True, exist_ok=True)
            elif rel.as_posix() != case.target:
                (dst / rel).parent.mkdir(parents=True, exist_ok=True)
                (dst / rel).symlink_to(p)
        path = dst / case.target
        path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


_BASELINES: dict[str, Any] = {}


def _baseline(b: Base, case: Case) -> Any:
    """JSON output of the command on the valid input (run once per case)."""
    if case.name not in _BASELINES:
        with tempfile.TemporaryDirectory(dir=b["dir"]) as tmp:
            work = Path(tmp)
            path = _work_copy(b, case, work, _target(b, case).read_bytes())
            outcome = run(case.argv(b, path, work))
            assert outcome.code == 0, outcome.err
            check_outcome(case, outcome, work, {})
            _BASELINES[case.name] = json.loads(outcome.out)
    return _BASELINES[case.name]


def _settings(case: Case) -> settings:
    return settings(
        max_examples=max(1, round(case.examples * EXAMPLES)),
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
        derandomize=False,
    )


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_reader_property(base: Base, case: Case) -> None:
    b = base
    if case.name == "cidco" and not CIDCO.is_dir():
        pytest.skip(f"CIDCO data not found under {CIDCO}")
    baseline = _baseline(b, case)
    data = _target(b, case).read_bytes()

    @_settings(case)
    @given(mutation=mutations(case, data))
    def prop(mutation: Mutated) -> None:
        with tempfile.TemporaryDirectory(dir=b["dir"]) as tmp:
            work = Path(tmp)
            path = _work_copy(b, case, work, mutation.data)
            outcome = run(case.argv(b, path, work))
            check_outcome(case, outcome, work, baseline)

    prop()


SPARSE_BYTES = 10 << 30
"""A sparse file of 10 GiB of NUL bytes (class 3 of issue 15: it used to cost 4 GB and hang)."""
PEAK_BYTES = 256 << 20
"""Most memory Python may allocate while refusing it (tracemalloc's peak; numpy counted)."""


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_a_huge_sparse_file_is_refused_after_one_block(
    base: Base, case: Case, tmp_path: Path
) -> None:
    if case.name == "cidco" and not CIDCO.is_dir():
        pytest.skip(f"CIDCO data not found under {CIDCO}")
    path = _work_copy(base, case, tmp_path, b"")
    os.truncate(path, SPARSE_BYTES)
    tracemalloc.start()
    try:
        outcome = run(case.argv(base, path, tmp_path))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    text = f"exit {outcome.code}\nstderr: {outcome.err[-3000:]}"
    assert outcome.code == 2, text
    assert outcome.err.count("\n") == 1, text
    assert str(path) in outcome.err or path.name in outcome.err, text
    assert peak < PEAK_BYTES, f"peak {peak / 2**20:.0f} MiB\n{text}"


@pytest.mark.parametrize("kind", ["mount.toml", "points.las", "points.laz", "ins.toml"])
def test_a_huge_sparse_mount_configuration_or_las_file_is_refused(
    base: Base, kind: str, tmp_path: Path
) -> None:
    path = tmp_path / kind
    path.touch()
    os.truncate(path, SPARSE_BYTES)
    if kind == "ins.toml":
        argv = _ins_args(base, "--out", tmp_path / "sol.csv", ins_config=path)
    else:
        suffix = "csv" if kind == "mount.toml" else kind.split(".")[1]
        argv = _georef(suffix)(base, base["points_csv"], tmp_path)
        argv[argv.index("--mount" if kind == "mount.toml" else "--points") + 1] = str(path)
    tracemalloc.start()
    try:
        outcome = run(argv)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert outcome.code == 2, outcome.err
    assert outcome.err.startswith(f"kinsync: error: {path}"), outcome.err
    assert outcome.err.count("\n") == 1, outcome.err
    assert peak < PEAK_BYTES, f"peak {peak / 2**20:.0f} MiB"
