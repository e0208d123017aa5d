"""Sphere fitting: accuracy and speed of kinsync against scikit-spatial and pyransac3d.

The same simulated clouds go to every method: the visible cap of a 0.1 m sphere 1.5 m
from a scanner at the origin, uniform in solid angle, with 2 mm range-only noise
(along the beam, as a scanner measures), 2 000 and 30 000 points, 50 clouds each
(pyransac3d: 20 of the 30 000-point clouds, at ~1.3 s a fit); and
the same caps with 10 % stray points in their bounding box for the methods that can
reject outliers (RANSAC). Prints the centre error (mean and RMS of |c - c_true|, and
the mean along-beam component, in micrometres), the median time per fit, and ratios.

Methods
    kinsync ortho    `fit_sphere` (Hyper start + Levenberg-Marquardt, orthogonal residual)
    kinsync ray      `fit_sphere(origin_m=...)` (range residual along each beam)
    kinsync segment  `segment_sphere(radius_bounds_m=(0.05, 0.2))` (+ ``origin_m``: ray)
    skspatial        `skspatial.objects.Sphere.best_fit` (linear least squares)
    pyransac3d       `pyransac3d.Sphere().fit(points, thresh=0.006)` (1000 iterations)

Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_sphere_fit.py``).
Timings depend on the machine and its load; nothing here is asserted.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pyransac3d as pyrsc
from skspatial.objects import Sphere as SkSphere

from kinsync.fit import fit_sphere, segment_sphere

CENTRE_M = np.array([1.5, 0.0, 0.0])
RADIUS_M = 0.1
ORIGIN_M = np.zeros(3)
RANGE_NOISE_M = 0.002
N_CLOUDS = 50
SIZES = (2_000, 30_000)
CLUTTER_FRACTION = 0.10
PYRSC_THRESH_M = 3.0 * RANGE_NOISE_M
PYRSC_MAX_CLOUDS_LARGE = 20

Fitter = Callable[[np.ndarray], np.ndarray]


def visible_cap(rng: np.random.Generator, n: int) -> np.ndarray:
    """Cap of the sphere seen from the origin, 2 mm range noise along each beam."""
    dist = float(np.linalg.norm(CENTRE_M))
    axis = CENTRE_M / dist
    cz = rng.uniform(math.sqrt(1.0 - (RADIUS_M / dist) ** 2), 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    sz = np.sqrt(1.0 - cz * cz)
    u = cz[:, None] * axis + sz[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    b = u @ CENTRE_M
    ranges = b - np.sqrt(np.maximum(b * b - dist * dist + RADIUS_M**2, 0.0))
    ranges += RANGE_NOISE_M * rng.standard_normal(n)
    pts: np.ndarray = ORIGIN_M + ranges[:, None] * u
    return pts


def with_clutter(rng: np.random.Generator, pts: np.ndarray) -> np.ndarray:
    n_stray = round(CLUTTER_FRACTION * len(pts))
    lo = pts.min(axis=0) - 0.05
    hi = pts.max(axis=0) + 0.05
    out: np.ndarray = rng.permutation(np.vstack([pts, rng.uniform(lo, hi, (n_stray, 3))]))
    return out


def kinsync_ortho(pts: np.ndarray) -> np.ndarray:
    return fit_sphere(pts).center_m


def kinsync_ray(pts: np.ndarray) -> np.ndarray:
    return fit_sphere(pts, origin_m=ORIGIN_M).center_m


def kinsync_segment(pts: np.ndarray) -> np.ndarray:
    return segment_sphere(pts, radius_bounds_m=(0.05, 0.2)).center_m


def kinsync_segment_ray(pts: np.ndarray) -> np.ndarray:
    return segment_sphere(pts, radius_bounds_m=(0.05, 0.2), origin_m=ORIGIN_M).center_m


def skspatial_fit(pts: np.ndarray) -> np.ndarray:
    return np.asarray(SkSphere.best_fit(pts).point, dtype=np.float64)


def pyransac3d_fit(pts: np.ndarray) -> np.ndarray:
    center, _radius, _inliers = pyrsc.Sphere().fit(pts, thresh=PYRSC_THRESH_M)
    return np.asarray(center, dtype=np.float64)


@dataclass(frozen=True)
class Row:
    method: str
    cloud_set: str
    n_points: int  # points on the sphere (strays come on top in the clutter set)
    errors_m: np.ndarray  # (K, 3)
    times_s: np.ndarray  # (K,)

    @property
    def mean_error_um(self) -> float:
        return float(np.linalg.norm(self.errors_m, axis=1).mean() * 1e6)

    @property
    def rms_error_um(self) -> float:
        return float(np.sqrt((np.linalg.norm(self.errors_m, axis=1) ** 2).mean()) * 1e6)

    @property
    def along_beam_bias_um(self) -> float:
        beam = CENTRE_M / np.linalg.norm(CENTRE_M)
        return float((self.errors_m @ beam).mean() * 1e6)

    @property
    def median_ms(self) -> float:
        return float(np.median(self.times_s) * 1e3)


def run(
    method: str, fitter: Fitter, clouds: list[np.ndarray], cloud_set: str, n_points: int
) -> Row:
    if method == "pyransac3d" and n_points > 10_000:
        clouds = clouds[:PYRSC_MAX_CLOUDS_LARGE]  # ~1.3 s a fit: keep the run short
    fitter(clouds[0])  # warm-up (imports, caches)
    errors, times = [], []
    for pts in clouds:
        t0 = time.perf_counter()
        centre = fitter(pts)
        times.append(time.perf_counter() - t0)
        errors.append(centre - CENTRE_M)
    return Row(method, cloud_set, n_points, np.array(errors), np.array(times))


def main() -> None:
    rng = np.random.default_rng(2024)
    random.seed(2024)  # pyransac3d samples with the random module
    rows: list[Row] = []
    for n in SIZES:
        clean = [visible_cap(rng, n) for _ in range(N_CLOUDS)]
        cluttered = [with_clutter(rng, pts) for pts in clean]
        for method, fitter in (
            ("kinsync ortho", kinsync_ortho),
            ("kinsync ray", kinsync_ray),
            ("skspatial", skspatial_fit),
            ("pyransac3d", pyransac3d_fit),
        ):
            rows.append(run(method, fitter, clean, "clean", n))
        for method, fitter in (
            ("kinsync segment", kinsync_segment),
            ("kinsync segment+ray", kinsync_segment_ray),
            ("pyransac3d", pyransac3d_fit),
        ):
            rows.append(run(method, fitter, cluttered, "10% clutter", n))

    print(
        f"Sphere R = {RADIUS_M} m at {np.linalg.norm(CENTRE_M)} m, one-sided cap, "
        f"{RANGE_NOISE_M * 1e3:g} mm range-only noise, {N_CLOUDS} clouds per set"
    )
    head = (
        f"{'method':<20} {'set':<12} {'N':>6} {'clouds':>6} | {'mean |err| um':>13} "
        f"{'RMS err um':>10} "
        f"{'beam bias um':>12} | {'median ms':>9}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r.method:<20} {r.cloud_set:<12} {r.n_points:>6} {len(r.times_s):>6} | "
            f"{r.mean_error_um:>13.1f} "
            f"{r.rms_error_um:>10.1f} {r.along_beam_bias_um:>12.1f} | {r.median_ms:>9.2f}"
        )

    def find(method: str, cloud_set: str, n: int) -> Row:
        return next(
            r for r in rows if r.method == method and r.cloud_set == cloud_set and r.n_points == n
        )

    print("\nRatios (> 1: kinsync better)")
    for n in SIZES:
        ortho = find("kinsync ortho", "clean", n)
        ray = find("kinsync ray", "clean", n)
        sk = find("skspatial", "clean", n)
        pr = find("pyransac3d", "clean", n)
        seg = find("kinsync segment", "10% clutter", n)
        seg_ray = find("kinsync segment+ray", "10% clutter", n)
        pr_c = find("pyransac3d", "10% clutter", n)
        print(f"  N = {n}")
        print(
            f"    RMS centre error, clean:   skspatial / kinsync ray = "
            f"{sk.rms_error_um / ray.rms_error_um:6.1f}   skspatial / kinsync ortho = "
            f"{sk.rms_error_um / ortho.rms_error_um:6.1f}   pyransac3d / kinsync ray = "
            f"{pr.rms_error_um / ray.rms_error_um:6.1f}"
        )
        print(
            f"    RMS centre error, clutter: pyransac3d / kinsync segment = "
            f"{pr_c.rms_error_um / seg.rms_error_um:6.1f}   pyransac3d / kinsync segment+ray = "
            f"{pr_c.rms_error_um / seg_ray.rms_error_um:6.1f}"
        )
        print(
            f"    time: pyransac3d / kinsync ortho = {pr.median_ms / ortho.median_ms:7.1f}   "
            f"pyransac3d / kinsync segment (clutter) = {pr_c.median_ms / seg.median_ms:7.1f}   "
            f"skspatial / kinsync ortho = {sk.median_ms / ortho.median_ms:5.2f}"
        )
    big = find("kinsync ortho", "clean", SIZES[-1])
    verdict = "met" if big.median_ms < 10.0 else "NOT met"
    print(
        f"\nkinsync ortho fit of {SIZES[-1]} points (algebraic start + geometric "
        f"refinement): median {big.median_ms:.2f} ms (target < 10 ms: {verdict})"
    )


if __name__ == "__main__":
    main()
