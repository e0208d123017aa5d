"""A rolling, turning trajectory and a scan over it, for the georeferencing pipeline tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from tests._las import las_points

from kinsync.io.trajectory_csv import write_trajectory_csv
from kinsync.trajectory import Trajectory

T0 = 1.3e9  # GPS time of the trajectory's first sample (s)


def write_trajectory(path: Path, duration_s: float) -> None:
    """A 100 Hz trajectory of ``duration_s`` from `T0`, near Québec City, as CSV."""
    t = T0 + np.arange(0.0, duration_s, 0.01)
    s = t - T0
    llh = np.column_stack([46.8 + 1e-5 * s, -71.2 + 2e-5 * s, 10.0 + 0.1 * s])
    traj = Trajectory.from_euler(
        t, 0.02 * np.sin(s), 0.01 * np.cos(0.5 * s), 0.3 + 0.05 * s, lat_lon_h=llh
    )
    write_trajectory_csv(traj, path)


def scan_columns(n: int, duration_s: float, seed: int) -> dict[str, np.ndarray]:
    """``n`` scanner points, ``t_s`` sorted from 0.5 s before the trajectory to 0.1 s
    before its end (so some lie outside its span), with an integer ``intensity``."""
    rng = np.random.default_rng(seed)
    return {
        "t_s": T0 + np.sort(rng.uniform(-0.5, duration_s - 0.1, n)),
        "x_m": rng.uniform(-1, 1, n),
        "y_m": rng.uniform(-20, 20, n),
        "z_m": rng.uniform(-5, 5, n),
        "intensity": rng.integers(0, 1000, n),
    }


def write_laz(cols: dict[str, np.ndarray], path: Path) -> None:
    """The columns as a LAZ file written by laspy (intensity as LAS intensity)."""
    las = las_points(cols)
    las.intensity = cols["intensity"].astype(np.uint16)
    las.write(path)


def nullable_points(n: int, duration_s: float, seed: int) -> pa.Table:
    """Points (some before the trajectory starts) with carried columns of many types.

    ``id`` numbers the rows; ``maybe`` has nulls only in rows 250..259 (a chunk of
    values first, then one with nulls); ``ok`` is null through rows 400..599 (a whole
    chunk without a value); ``return_id`` is beyond float64's integers.
    """
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    return pa.table(
        {
            "t_s": T0 + np.sort(rng.uniform(-0.5, duration_s - 0.1, n)),
            "x_m": rng.uniform(-1, 1, n),
            "y_m": rng.uniform(-20, 20, n),
            "z_m": rng.uniform(-5, 5, n),
            "id": pa.array(k, pa.int64()),
            "intensity": pa.array(k % 4000, pa.int32()),
            "return_id": pa.array(2**62 + k, pa.int64()),
            "maybe": pa.array([None if 250 <= i < 260 else i % 300 for i in k], pa.int16()),
            "ok": pa.array([None if 400 <= i < 600 else bool(i % 2) for i in k]),
            "refl": pa.array([None if i % 7 == 0 else i / 8 for i in k], pa.float32()),
            "label": pa.array([None if i % 11 == 0 else f"p{i}" for i in k]),
            "u8": pa.array(k % 256, pa.uint8()),
        }
    )


def csv_points(folder: Path) -> tuple[Path, bytes, list[bytes]]:
    """A CSV (BOM, CRLF, odd spellings) and the header and lines of its rows outside."""
    header = "\ufefft_s,x_m,y_m,z_m,code,big,amp\r\n".encode()
    outside = [
        b"1299999999.123456789,1.50,+2,-3e0,007,73786976294838206464,\r\n",
        b'1299999999.500000000001,0.1, 2.0,3,"a,b",1,1E-320\r\n',
    ]
    inside = [f"{T0 + 1 + i / 10!r},0.5,{i},-1.0,{i:03d},{i},0.25\r\n".encode() for i in range(40)]
    late = b"1300000100.0,1,2,3,x,2,3"  # after the end, no line end
    data = header + outside[0] + inside[0] + b"\r\n" + outside[1] + b"".join(inside[1:]) + late
    path = folder / "points.csv"
    path.write_bytes(data)
    return path, header, [*outside, late + b"\n"]
