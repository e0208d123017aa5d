"""PROJ_NETWORK=ON on a host without network: a missing geoid grid is named, not a crash.

With the network enabled PROJ counts every grid of its CDN as available, so it chose a
transformation needing the geoid grid, then failed to build it: ``ProjError: Invalid
projection proj=pipeline ...``, an internal error (exit 1). The network is cut here by
pointing PROJ at a closed local port, in a child process (PROJ reads its network
settings when a context starts), with its grid cache in a temporary folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pyproj
import pytest

_SCRIPT = """
import numpy as np, pyproj
from kinsync.crs import crs_to_ecef_transformer, plan_ecef_to_crs
from kinsync.errors import InputError
assert pyproj.network.is_network_enabled()
to_ecef = pyproj.Transformer.from_crs(4979, 4978, always_xy=True)
sample = np.array([to_ecef.transform(-71.2, 46.8, 10.0)])
for run in (lambda: plan_ecef_to_crs("EPSG:32619+5703", sample_ecef_m=sample),
            lambda: crs_to_ecef_transformer("EPSG:32619+3855")):
    try:
        run()
        print("no error")
    except InputError as err:
        print("InputError:", err)
"""


def _has_local_grids() -> bool:
    dirs = [pyproj.datadir.get_data_dir(), pyproj.datadir.get_user_data_dir()]  # type: ignore[attr-defined]
    return any(any(Path(d).glob("*.tif")) for d in dirs if Path(d).is_dir())


def test_a_grid_proj_cannot_download_is_named_with_the_usual_advice(tmp_path: Path) -> None:
    if _has_local_grids():
        pytest.skip("PROJ has grids installed here: it needs no download")
    env = {
        **os.environ,
        "PROJ_NETWORK": "ON",
        "PROJ_NETWORK_ENDPOINT": "http://127.0.0.1:9",  # the discard port: refused at once
        "PROJ_USER_WRITABLE_DIRECTORY": str(tmp_path),
    }
    proc = subprocess.run(
        [sys.executable, "-c", _SCRIPT], capture_output=True, text=True, check=False, env=env
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 2, proc.stdout
    for line, crs in zip(lines, ("EPSG:32619+5703", "EPSG:32619+3855"), strict=True):
        assert line.startswith(f"InputError: --crs {crs!r}: orthometric heights need the grid ")
        assert "(geoid model)" in line
        assert "`projsync --file " in line
        assert "PROJ_NETWORK=ON could not download it" in line
        assert "--geoid PATH" in line
