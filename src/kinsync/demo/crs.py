"""Demo section: CRS, datums, epochs and geoid heights on a survey near Québec City.

What a surveyor meets when a georeferenced cloud leaves kinsync: the UTM zone of the data
and the scale error of the wrong one, a time-dependent datum change (ITRF2014 to
NAD83(CSRS)v8) evaluated at the data's epoch or another, orthometric heights from a geoid
grid, and the refusal to label ellipsoidal heights as orthometric when the grid is missing.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pyproj

from kinsync._typing import FloatArray
from kinsync.crs import (
    CrsTransformInfo,
    DataArea,
    crs_plan_transformer,
    data_area,
    plan_ecef_to_crs,
)
from kinsync.demo.tolerances import EXACT, GEOREF_KERNEL
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_write_text
from kinsync.io.gtx import write_gtx
from kinsync.report.html import Section, Table
from kinsync.report.verdict import Check

__all__ = ["crs_section"]

Summary = list[tuple[str, str, str]]

OBSERVATION_EPOCH = 2024.96  # the simulated survey's date (December 2024), decimal year
OTHER_EPOCH = 2010.0  # NAD83(CSRS)v8's reference epoch, a common wrong default
GEOID_N_M = -28.6  # about CGG2013's geoid height at Québec City (m)
_WGS84_LLH = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


@dataclass(frozen=True, eq=False)
class _CrsRun:
    """The plans of every case and what they did to the survey's points."""

    area: DataArea
    right: CrsTransformInfo
    wrong: CrsTransformInfo
    csrs_now: CrsTransformInfo
    epoch_shift_m: float
    epoch_vs_proj_m: float
    geoid: CrsTransformInfo
    geoid_error_m: float
    missing_grid: str


def _survey_points() -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """A 2 km drive near Québec City: lat, lon, h and ECEF (m)."""
    s = np.linspace(0.0, 1.0, 50)
    lat, lon, h = 46.80 + 0.01 * s, -71.21 + 0.02 * s, 10.0 + 30.0 * s
    x, y, z = _WGS84_LLH.transform(lon, lat, h)
    return lat, lon, h, np.column_stack([x, y, z])


def _apply(plan_info: tuple[Any, CrsTransformInfo], pos_ecef_m: FloatArray) -> FloatArray:
    transform = crs_plan_transformer(plan_info[0])
    assert transform is not None
    return transform(pos_ecef_m)


def _run(out_dir: Path) -> _CrsRun:
    lat, lon, h, pos = _survey_points()
    area = data_area(lat, lon, h)
    right = plan_ecef_to_crs(area.utm_epsg, sample_ecef_m=pos)[1]
    assert area.utm_zone is not None  # Québec City is within UTM's limits
    wrong_zone = f"EPSG:326{area.utm_zone - 1:02d}"
    wrong = plan_ecef_to_crs(wrong_zone, sample_ecef_m=pos)[1]
    csrs = {
        epoch: plan_ecef_to_crs(
            "EPSG:22819",
            source_crs="EPSG:7789",
            epoch_year=epoch,
            sample_ecef_m=pos,
            observation_epoch_year=OBSERVATION_EPOCH,
        )
        for epoch in (OBSERVATION_EPOCH, OTHER_EPOCH)
    }
    now, then = (_apply(csrs[e], pos) for e in (OBSERVATION_EPOCH, OTHER_EPOCH))
    epoch_shift_m = float(np.max(np.hypot(*(now - then)[:, :2].T)))
    # PROJ's own 4-D transformation of the same points at the data's epoch.
    direct = pyproj.Transformer.from_crs("EPSG:7789", "EPSG:22819", always_xy=True)
    epochs = np.full(len(pos), OBSERVATION_EPOCH)
    e, n, u, _ = direct.transform(pos[:, 0], pos[:, 1], pos[:, 2], epochs)
    epoch_vs_proj_m = float(np.max(np.abs(now - np.column_stack([e, n, u]))))
    grid = out_dir / "crs_demo_geoid.gtx"
    write_gtx(grid, 46.3, -71.7, 0.05, np.full((21, 21), GEOID_N_M))
    geoid_plan = plan_ecef_to_crs("EPSG:32619+5703", geoid=str(grid), sample_ecef_m=pos)
    heights = _apply(geoid_plan, pos)[:, 2]
    geoid_error_m = float(np.max(np.abs(heights - (h - GEOID_N_M))))
    try:
        plan_ecef_to_crs("EPSG:32619+5703", sample_ecef_m=pos)
        missing = "PROJ has this geoid grid here (installed or PROJ_NETWORK=ON): no refusal"
    except InputError as err:  # the report stays offline: no address in it, even as text
        missing = re.sub(r"https?://\S+", "PROJ's CDN", str(err))
    return _CrsRun(
        area=area,
        right=right,
        wrong=wrong,
        csrs_now=csrs[OBSERVATION_EPOCH][1],
        epoch_shift_m=epoch_shift_m,
        epoch_vs_proj_m=epoch_vs_proj_m,
        geoid=_grid_named_in_folder(geoid_plan[1], grid),
        geoid_error_m=geoid_error_m,
        missing_grid=missing,
    )


def _grid_named_in_folder(info: CrsTransformInfo, grid: Path) -> CrsTransformInfo:
    """``info`` with the grid named by its file name, as the report folder holds it.

    The demo writes into a temporary folder renamed into place when complete: the grid's
    full path there would be a folder that no longer exists when the report is read.
    """
    full = str(grid)

    def named(text: str) -> str:
        return text.replace(full, grid.name)

    return replace(
        info,
        operation=named(info.operation),
        proj_pipeline=named(info.proj_pipeline),
        heights=named(info.heights),
        geoid=None if info.geoid is None else named(info.geoid),
        warnings=tuple(named(w) for w in info.warnings),
    )


def _accuracy(info: CrsTransformInfo) -> str:
    return "unknown" if info.accuracy_m is None else f"{info.accuracy_m:g} m"


def _table(run: _CrsRun) -> Table:
    rows = [
        [f"--crs {run.area.utm_epsg} (the data's zone)", run.right.operation,
         _accuracy(run.right), "; ".join(run.right.warnings) or "none"],
        [f"--crs {run.wrong.target.split('(')[-1].rstrip(')')} (the zone west)",
         run.wrong.operation, _accuracy(run.wrong), "; ".join(run.wrong.warnings)],
        ["--trajectory-crs EPSG:7789 --crs EPSG:22819", run.csrs_now.operation,
         _accuracy(run.csrs_now),
         (f"time-dependent, epoch {run.csrs_now.epoch_year:.2f} (the data's); at "
          f"{OTHER_EPOCH:g} the points move {run.epoch_shift_m * 100:.1f} cm")],
        ["--crs EPSG:32619+5703 --geoid grid.gtx", run.geoid.operation, _accuracy(run.geoid),
         f"heights {run.geoid.heights}; H = h - N within {run.geoid_error_m * 1e3:.3f} mm"],
        ["--crs EPSG:32619+5703 (no grid)", "-", "-", run.missing_grid],
    ]  # fmt: skip
    return Table(
        caption="What kinsync georef reports (and in --json under crs) for each --crs",
        headers=["options", "PROJ operation", "accuracy", "epoch, heights, warnings"],
        rows=rows,
    )


def _checks(run: _CrsRun) -> tuple[Check, ...]:
    warned = any("ppm" in w for w in run.wrong.warnings)
    return (
        Check(
            "ITRF2014 -> NAD83(CSRS)v8 at the data's epoch, against PROJ's 4-D transformation",
            run.epoch_vs_proj_m * 1e3,
            GEOREF_KERNEL,
            detail=f"the epoch moves the points {run.epoch_shift_m * 100:.1f} cm since 2010",
        ),
        Check(
            "orthometric heights from the --geoid grid, against h - N",
            run.geoid_error_m * 1e3,
            GEOREF_KERNEL,
        ),
        Check(
            "UTM zone of the wrong side used without a warning",
            0.0 if warned else 1.0,
            EXACT,
            detail="warned, with the scale error" if warned else "no warning",
        ),
    )


def _document(run: _CrsRun) -> dict[str, Any]:
    return {
        "area": run.area.as_document(),
        "right_zone": run.right.as_document(),
        "wrong_zone": run.wrong.as_document(),
        "itrf2014_to_csrs_v8": run.csrs_now.as_document(),
        "epoch_shift_m": run.epoch_shift_m,
        "epoch_vs_proj_m": run.epoch_vs_proj_m,
        "geoid": run.geoid.as_document(),
        "geoid_height_error_m": run.geoid_error_m,
        "missing_grid": run.missing_grid,
    }


def crs_section(out_dir: Path, summary: Summary) -> Section:
    """Plan and apply each CRS case on a simulated survey; write ``crs.json``."""
    run = _run(out_dir)
    atomic_write_text(out_dir / "crs.json", json.dumps(_document(run), indent=2) + "\n")
    summary.append(
        (
            "CRS and datums",
            "survey near Québec City, December 2024",
            (
                f"UTM zone {run.area.zone_name} suggested; wrong "
                f"epoch {run.epoch_shift_m * 100:.1f} cm; geoid heights within "
                f"{run.geoid_error_m * 1e3:.2g} mm"
            ),
        )
    )
    lat0, lat1 = run.area.lat_deg
    lon0, lon1 = run.area.lon_deg
    return Section(
        title="Coordinate systems, datums, epochs and geoid heights",
        paragraphs=(
            (
                f"A 2 km drive at latitude {lat0:.2f} to {lat1:.2f}°, longitude {lon0:.2f} "
                f"to {lon1:.2f}°: `kinsync trajectory info` suggests UTM zone "
                f"{run.area.zone_name} ({run.area.utm_epsg}). The "
                "zone to the west is allowed but warned about, with the scale error it would "
                "put into every distance."
            ),
            (
                "An SBET processed in ITRF2014 and delivered in NAD83(CSRS)v8 goes through a "
                "time-dependent Helmert transformation: kinsync evaluates it at the data's "
                f"own epoch ({OBSERVATION_EPOCH:g}, from the GPS times) unless --epoch says "
                f"otherwise; evaluated at {OTHER_EPOCH:g} instead, every point would move by "
                f"{run.epoch_shift_m * 100:.1f} cm."
            ),
            (
                "Orthometric heights (NAVD88, EPSG:5703; here from a synthetic grid, geoid "
                f"N = {GEOID_N_M:g} m) come from a compound CRS and a geoid grid given with "
                "--geoid; without the grid PROJ would keep ellipsoidal heights under the "
                "orthometric label, so kinsync stops and names the grid and how to get it."
            ),
        ),
        tables=(_table(run),),
        checks=_checks(run),
    )
