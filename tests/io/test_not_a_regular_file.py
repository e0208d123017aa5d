"""Readers name a symbolic link loop, a pipe or a device as what it is.

A loop of symbolic links read as "pass folder not found" or "cannot read the
trajectory export (Too many levels of symbolic links)"; a pipe or a device given as a
point file read as "file not found", as an SBET as "empty file", and as a TOML file it
waited for a writer for ever.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kinsync.errors import InputError
from kinsync.io.mount_file import read_toml_text
from kinsync.io.passes import read_passes, write_passes
from kinsync.io.points import table_columns
from kinsync.io.profile_scan import read_clock_document, read_profile_scan
from kinsync.io.sanity import require_file
from kinsync.io.trajectory import read_trajectory_file
from kinsync.latency.passes import SpherePass
from kinsync.mount import Mount
from kinsync.pipelines.sync_apply import apply_profile_clock

needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")


def _loop(tmp_path: Path, name: str) -> Path:
    loop = tmp_path / name
    loop.symlink_to(name)
    return loop


@contextlib.contextmanager
def _fifo(tmp_path: Path, name: str) -> Iterator[Path]:
    """A named pipe with a writer, so that a reader that opens it gets an end, not a hang."""
    fifo = tmp_path / name
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_bytes, args=(b"x = 1\n",), daemon=True)
    writer.start()
    try:
        yield fifo
    finally:
        fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # the writer's open returns
        writer.join()
        os.close(fd)


PROFILER = Mount(profiler_azimuth_deg=0.0)
READERS: dict[str, tuple[str, Callable[[Path], Any]]] = {
    "trajectory export": ("t.txt", read_trajectory_file),
    "SBET": ("t.out", read_trajectory_file),
    "trajectory CSV": ("t.csv", read_trajectory_file),
    "point table": ("p.csv", table_columns),
    "point file": ("p.laz", require_file),
    "pass folder": ("passes", read_passes),
    "mount file": ("m.toml", lambda p: read_toml_text(p, "mount file")),
    # a link loop given as a clock file read as "clock file not found"
    "clock file": ("c.json", read_clock_document),
    "scan": ("s.csv", read_profile_scan),
    "scan to apply": (
        "s.csv",
        lambda p: apply_profile_clock(p, p.with_name("o.csv"), 0.0, 0.03, PROFILER),
    ),
}


@needs_fifo
@pytest.mark.parametrize("kind", ["scan", "scan to apply"])
def test_a_pipe_given_as_a_scan_is_called_a_scan(tmp_path: Path, kind: str) -> None:
    """It was called a 'point table', the reader's word for georef's input."""
    name, read = READERS[kind]
    with _fifo(tmp_path, name) as fifo, pytest.raises(InputError, match="give the scan as a file"):
        read(fifo)


@pytest.mark.parametrize("kind", list(READERS))
def test_a_symbolic_link_loop_is_named(tmp_path: Path, kind: str) -> None:
    name, read = READERS[kind]
    loop = _loop(tmp_path, name)
    with pytest.raises(InputError, match=rf"^{loop}: symbolic link loop \("):
        read(loop)


@needs_fifo
@pytest.mark.parametrize("kind", [k for k in READERS if k != "pass folder"])
def test_a_pipe_is_named(tmp_path: Path, kind: str) -> None:
    name, read = READERS[kind]
    with (
        _fifo(tmp_path, name) as fifo,
        pytest.raises(InputError, match=rf"^{fifo}: not a regular file \(a device or a pipe\)"),
    ):
        read(fifo)


def test_a_device_given_as_a_point_file_is_named(tmp_path: Path) -> None:
    if not Path(os.devnull).exists():
        pytest.skip("no null device here")
    link = tmp_path / "p.csv"
    link.symlink_to(os.devnull)
    with pytest.raises(InputError, match="not a regular file"):
        require_file(link, "point file")
    with pytest.raises(InputError, match="not a regular file"):
        table_columns(link)


def _pass_folder(tmp_path: Path) -> tuple[Path, Path]:
    rng = np.random.default_rng(0)
    passes = [SpherePass(f"p{i}", 6.0, rng.normal(size=(20, 3))) for i in range(2)]
    folder = tmp_path / "passes"
    write_passes(folder, passes)
    second = sorted(folder.glob("pass_*.csv"))[1]
    second.unlink()
    return folder, second


def test_a_pass_file_that_is_a_folder_is_named(tmp_path: Path) -> None:
    # Was "pass file 'pass_001.csv' not found".
    folder, second = _pass_folder(tmp_path)
    second.mkdir()
    with pytest.raises(InputError, match=rf"'{second.name}' in {folder} is a folder, not a file"):
        read_passes(folder)


def test_a_pass_file_that_is_a_link_loop_is_named(tmp_path: Path) -> None:
    folder, second = _pass_folder(tmp_path)
    second.symlink_to(second.name)
    with pytest.raises(InputError, match=rf"pass file '{second.name}': symbolic link loop"):
        read_passes(folder)


@needs_fifo
def test_a_pass_file_that_is_a_pipe_is_named(tmp_path: Path) -> None:
    folder, second = _pass_folder(tmp_path)
    with (
        _fifo(tmp_path / "passes", second.name),
        pytest.raises(InputError, match=rf"'{second.name}': not a regular file"),
    ):
        read_passes(folder)
