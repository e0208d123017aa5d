"""First-run cost of the command line: cold and warm time per command, start-up, memory.

numba compiles a command's kernels the first time they run and keeps them in its cache;
a user's first command pays the compilation. For each command that compiles kernels
this prints, side by side,

- **cold**: a fresh process with an empty numba cache (``NUMBA_CACHE_DIR`` a new empty
  folder), as on a fresh install;
- **warm**: the same command again in a fresh process with the cache the cold run left;
- their ratio, and the peak resident memory of each (``VmHWM`` of the command's own
  process, read as it exits);

and, for a command that does no work, the start-up: ``kinsync --help``,
``kinsync ins run --help`` and ``kinsync budget serial``, against a bare ``python -c
pass`` measured in the same run (time and peak memory).

The inputs are simulated first (``kinsync simulate ...``, with a cache of their own, so
their compilation is not counted), in a temporary folder removed afterwards. Times are
medians of ``--repeat`` runs (a 2-core machine shared with others is noisy). With
``--baseline SRC`` every figure is measured a second time with ``PYTHONPATH=SRC`` (an
older checkout's ``src``) and printed beside it, interleaved run by run, so that a
change is compared on the same machine at the same moment. ``--demo`` adds
``kinsync demo`` (minutes per run). Linux only (``/proc/self/status``).

Run: ``.venv/bin/python benchmarks/bench_first_run.py [--repeat 3] [--only ins]
[--baseline OLD/src] [--demo]``.
"""

# The parent imports the standard library only: the children's memory is theirs.
from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_LAUNCHER = """
import atexit, os, re, runpy, sys
def _hwm():
    with open("/proc/self/status") as f:
        kb = re.search(r"VmHWM:\\s+(\\d+)", f.read()).group(1)
    with open(os.environ["KINSYNC_BENCH_HWM"], "w") as f:
        f.write(kb)
atexit.register(_hwm)
sys.argv = ["kinsync", *sys.argv[1:]]
runpy.run_module("kinsync", run_name="__main__", alter_sys=True)
"""
"""``python -m kinsync ARGS`` that writes its peak resident memory (kB) on the way out."""


@dataclass(frozen=True)
class Run:
    """One process: wall time (s), CPU time (s, user + system) and peak memory (MB)."""

    seconds: float
    cpu_s: float
    peak_mb: float


@dataclass(frozen=True)
class Command:
    """A command line measured cold and warm; ``args`` get the data folder and a scratch."""

    name: str
    args: Callable[[Path, Path], list[str]]


def kinsync_run(
    args: list[str], *, cache: Path, src: Path | None, cwd: Path, stdout: Path | None = None
) -> Run:
    """Run ``kinsync ARGS`` in a fresh process with numba's cache in ``cache``."""
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(cache)
    env["COLUMNS"] = "100"
    if src is not None:
        env["PYTHONPATH"] = str(src)
    hwm = cwd / ".hwm"
    env["KINSYNC_BENCH_HWM"] = str(hwm)
    cpu0 = _children_cpu_s()
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _LAUNCHER, *args],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        check=False,
    )
    seconds = time.perf_counter() - start
    cpu_s = _children_cpu_s() - cpu0
    if proc.returncode != 0:
        msg = f"kinsync {' '.join(args)} exited {proc.returncode}:\n{proc.stderr[-2000:]}"
        raise RuntimeError(msg)
    if stdout is not None:
        stdout.write_text(proc.stdout, encoding="utf-8")
    peak_kb = float(hwm.read_text()) if hwm.exists() else float("nan")
    hwm.unlink(missing_ok=True)
    return Run(seconds, cpu_s, peak_kb / 1024.0)


def bare_python() -> Run:
    """``python -c pass`` (its peak memory read the same way)."""
    code = 'import re; print(re.search(r"VmHWM:\\s+(\\d+)", open("/proc/self/status").read())[1])'
    cpu0 = _children_cpu_s()
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - start
    return Run(seconds, _children_cpu_s() - cpu0, float(out.stdout) / 1024.0)


def _children_cpu_s() -> float:
    """User + system CPU time of the finished child processes so far (s)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


# ---------------------------------------------------------------------- the inputs
def make_inputs(data: Path, cache: Path) -> None:
    """Simulated inputs of every measured command (their compile time is not counted)."""
    steps = [
        ["simulate", "drive", "--out", "drive", "--json"],
        ["simulate", "rotating-table", "--out", "table", "--format", "laz", "--raw", "--json"],
        ["simulate", "drive-scan", "--out", "scan", "--json"],
        ["simulate", "patch-test", "--scenario", "vehicle", "--out", "patch", "--json"],
        ["simulate", "clock", "--out", "clock", "--json"],
    ]
    for args in steps:
        kinsync_run(args, cache=cache, src=None, cwd=data)
    clock = data / "clock.json"  # the input of sync apply
    kinsync_run(SYNC_OBJECT_SPACE.args(data, data), cache=cache, src=None, cwd=data, stdout=clock)


SYNC_OBJECT_SPACE = Command(
    "sync object-space",
    lambda d, _o: [
        "sync", "object-space", "--scan", str(d / "scan/scan.csv"),
        "--trajectory", str(d / "scan/trajectory.csv"), "--mount", str(d / "scan/mount.toml"),
        "--sync-points", str(d / "scan/sync_points.csv"), "--pulses", str(d / "scan/pulses.csv"),
        "--period-prior-s", "0.0303", "--period-tolerance", "0.01", "--json",
    ],
)  # fmt: skip

_INS = ["ins", "run", "--imu", "drive/imu.csv", "--gnss", "drive/gnss.csv"]


def _simulate(kind: str, folder: str) -> Command:
    """``kinsync simulate KIND`` into the scratch folder ``folder``."""
    return Command(
        f"simulate {kind}", lambda _d, o: ["simulate", kind, "--out", str(o / folder), "--json"]
    )


COMMANDS: tuple[Command, ...] = (
    Command(
        "ins run",
        lambda d, o: [*_INS, "--config", str(d / "drive/ins.toml"), "--out", str(o / "n.csv")],
    ),
    Command(
        "ins run --smooth",
        lambda d, o: [
            *_INS,
            "--config",
            str(d / "drive/ins.toml"),
            "--smooth",
            "--out",
            str(o / "s.csv"),
        ],
    ),
    Command(
        "georef (LAZ -> LAZ)",
        lambda d, o: [
            "georef",
            "--points",
            str(d / "patch/line_01.laz"),
            "--trajectory",
            str(d / "patch/trajectory.out"),
            "--gps-week",
            "2345",
            "--mount",
            str(d / "patch/mount.toml"),
            "--out",
            str(o / "cloud.laz"),
            "--json",
        ],
    ),
    Command("latency sphere", lambda d, _o: ["latency", "sphere", str(d / "table"), "--no-figure"]),
    Command(
        "latency sphere --raw",
        lambda d, _o: ["latency", "sphere", str(d / "table"), "--raw", "--no-figure"],
    ),
    SYNC_OBJECT_SPACE,
    Command(
        "sync apply",
        lambda d, o: [
            "sync",
            "apply",
            "--scan",
            str(d / "scan/scan.csv"),
            "--mount",
            str(d / "scan/mount.toml"),
            "--clock",
            str(d / "clock.json"),
            "--out",
            str(o / "timed.csv"),
            "--json",
        ],
    ),
    Command(
        "calibrate mount",
        lambda d, _o: [
            "calibrate",
            "mount",
            "--points",
            *(str(p) for p in sorted(d.glob("patch/line_*.laz"))),
            "--trajectory",
            str(d / "patch/trajectory.out"),
            "--gps-week",
            "2345",
            "--mount",
            str(d / "patch/mount.toml"),
            "--features",
            "planes",
            "--json",
        ],
    ),
    Command(
        "clock fit",
        lambda d, _o: [
            "clock",
            "fit",
            "--pps",
            str(d / "clock/pps.csv"),
            "--nmea",
            str(d / "clock/nmea.csv"),
            "--json",
        ],
    ),
    *(
        _simulate(kind, folder)
        for kind, folder in (
            ("drive", "sim-drive"),
            ("rotating-table", "sim-table"),
            ("drive-scan", "sim-scan"),
            ("patch-test", "sim-patch"),
        )
    ),
)
DEMO = Command("demo", lambda _d, o: ["demo", "--out", str(o / "demo-output")])

START_UP: tuple[tuple[str, list[str]], ...] = (
    ("kinsync --version", ["--version"]),
    ("kinsync --help", ["--help"]),
    ("kinsync ins run --help", ["ins", "run", "--help"]),
    ("kinsync budget serial", ["budget", "serial", "--baud", "9600", "--bytes", "16", "--json"]),
)


# ---------------------------------------------------------------------- measuring
def cold_and_warm(command: Command, data: Path, src: Path | None, scratch: Path) -> tuple[Run, Run]:
    """One cold run (empty cache) and one warm run (the cache it left), fresh processes."""
    cache = Path(tempfile.mkdtemp(prefix="numba-cold-", dir=scratch))
    out = Path(tempfile.mkdtemp(prefix="out-", dir=scratch))
    try:
        cold = kinsync_run(command.args(data, out), cache=cache, src=src, cwd=data)
        shutil.rmtree(out)
        out.mkdir()
        warm = kinsync_run(command.args(data, out), cache=cache, src=src, cwd=data)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
        shutil.rmtree(out, ignore_errors=True)
    return cold, warm


def median_run(runs: list[Run]) -> Run:
    """Median wall time, CPU time and peak memory."""
    return Run(
        statistics.median(r.seconds for r in runs),
        statistics.median(r.cpu_s for r in runs),
        statistics.median(r.peak_mb for r in runs),
    )


def fmt_pair(colds: list[Run], warms: list[Run]) -> str:
    """Cold wall (min-max), cold CPU, warm wall, warm CPU, cold/warm ratio, memory."""
    cold, warm = median_run(colds), median_run(warms)
    spread = f"{min(r.seconds for r in colds):.0f}-{max(r.seconds for r in colds):.0f}"
    return (
        f"{cold.seconds:6.1f} {spread:>7s} {cold.cpu_s:6.1f} {warm.seconds:6.1f}"
        f" {warm.cpu_s:6.1f} {cold.seconds / warm.seconds:5.1f}x"
        f" {cold.peak_mb:5.0f} {warm.peak_mb:5.0f}"
    )


HEAD = "  cold s  (range) cpu  s  warm s cpu  s  ratio MB cold warm"


def measure_commands(
    commands: list[Command], data: Path, scratch: Path, repeat: int, baseline: Path | None
) -> None:
    """Print the cold/warm table (and the baseline's beside it, measured alternately)."""
    print(f"\ncold: empty numba cache; warm: the cache it left. Wall medians of {repeat} runs")
    print("with their range, CPU seconds (user + system: less shaken by a busy machine).")
    print(f"{'command':24s}{HEAD}" + (f" | baseline{HEAD}" if baseline else ""))
    worst = {"this": (0.0, 0.0), "base": (0.0, 0.0)}
    for command in commands:
        runs: dict[str, list[tuple[Run, Run]]] = {"this": [], "base": []}
        for _ in range(repeat):
            runs["this"].append(cold_and_warm(command, data, None, scratch))
            if baseline is not None:
                runs["base"].append(cold_and_warm(command, data, baseline, scratch))
        line = f"{command.name:24s}"
        for key in ("this", "base"):
            if not runs[key]:
                continue
            colds = [c for c, _ in runs[key]]
            cold = median_run(colds)
            worst[key] = max(worst[key], (cold.seconds, cold.cpu_s))
            line += (" | " if key == "base" else "") + fmt_pair(colds, [w for _, w in runs[key]])
        print(line, flush=True)
    this, base = worst["this"], worst["base"]
    print(f"worst cold time: {this[0]:.1f} s wall, {this[1]:.1f} s CPU (target < 20 s)", end="")
    print(f"; baseline {base[0]:.1f} s wall, {base[1]:.1f} s CPU" if baseline else "")


def measure_start_up(scratch: Path, repeat: int, baseline: Path | None) -> None:
    """Start-up time and peak memory of commands that do no work, against bare python."""
    bare = median_run([bare_python() for _ in range(repeat)])
    cache = scratch / "numba-start-up"
    cache.mkdir(exist_ok=True)
    print(
        f"\nstart-up, median of {repeat} (bare python: {bare.seconds:.3f} s, "
        f"{bare.peak_mb:.0f} MB):"
    )
    print(
        f"{'command':26s}      s  x python     MB"
        + ("   | baseline s  x python     MB" if baseline else "")
    )
    for name, args in START_UP:
        line = f"{name:26s}"
        for src in (None, baseline) if baseline else (None,):
            r = median_run(
                [kinsync_run(args, cache=cache, src=src, cwd=scratch) for _ in range(repeat)]
            )
            line += ("   |   " if src else " ") + (
                f"{r.seconds:6.2f} {r.seconds / bare.seconds:8.1f}x {r.peak_mb:6.0f}"
            )
        print(line, flush=True)
    for src in (None, baseline) if baseline else (None,):
        print_import_time(src)


def print_import_time(src: Path | None, top: int = 6) -> None:
    """``python -X importtime -m kinsync --help``: total and the largest packages loaded."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "kinsync", "--help"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    total = 0.0  # the modules imported at the top level, with what they import (s)
    package: dict[str, float] = {}  # each top-level package, where first imported (s)
    for line in proc.stderr.splitlines():
        parts = line.split("|")
        if not line.startswith("import time:") or len(parts) != 3 or not parts[1].strip().isdigit():
            continue
        seconds = float(parts[1]) * 1e-6
        name = parts[2][1:]
        if not name.startswith(" "):
            total += seconds
        name = name.strip()
        if "." not in name:
            package[name] = max(package.get(name, 0.0), seconds)
    largest = sorted(package.items(), key=lambda kv: -kv[1])[:top]
    label = "this" if src is None else "baseline"
    print(
        f"imports of kinsync --help ({label}): {total:.2f} s; largest: "
        + ", ".join(f"{name} {seconds:.2f}" for name, seconds in largest)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per figure (median)")
    parser.add_argument("--only", default="", help="measure the commands containing this")
    parser.add_argument("--baseline", type=Path, help="another checkout's src to compare")
    parser.add_argument("--demo", action="store_true", help="also kinsync demo (minutes)")
    parser.add_argument("--no-start-up", action="store_true", help="skip the start-up part")
    args = parser.parse_args()
    baseline = args.baseline.resolve() if args.baseline else None
    commands = [c for c in COMMANDS if args.only in c.name]
    if args.demo:
        commands.append(DEMO)
    with tempfile.TemporaryDirectory(prefix="kinsync-first-run-") as tmp:
        scratch = Path(tmp)
        data = scratch / "data"
        data.mkdir()
        print(f"simulating the inputs in {data} ...", flush=True)
        setup_cache = scratch / "numba-setup"
        setup_cache.mkdir()
        make_inputs(data, setup_cache)
        if not args.no_start_up:
            measure_start_up(scratch, args.repeat, baseline)
        measure_commands(commands, data, scratch, args.repeat, baseline)


if __name__ == "__main__":
    main()
