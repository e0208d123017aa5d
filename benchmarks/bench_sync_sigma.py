"""Method B: is the reported sigma of the clock honest on INS-like trajectory errors?

A Monte Carlo of the object-space synchronisation (`kinsync.sync.object_space`): each
run scans the same simulated drive again (new scan noise, new clock phase), adds a
new position error to the trajectory, synchronises, and the spread of the clock's
errors is compared with the sigma it reports: ``RMS(error) / RMS(sigma)`` should be 1
(sampling error about ``1 / sqrt(2 N)`` for N runs; [0.8, 1.25] is the goal).

Trajectory errors, 2 cm isotropic (the same sigma on N, E and D):

* ``GM x s``: first-order Gauss-Markov, correlation ``exp(-|dt| / x)``; ``GM 15 s``
  is the fit's model with its default correlation time, ``GM 5 s`` and ``GM 40 s``
  INS/GNSS solutions whose errors change faster or slower than assumed, ``GM 0.3 s``
  errors independent from one sighting to the next (the old model's assumption);
* ``spline 20 s``: `kinsync.sim.nav_noise.noisy_trajectory`, a smooth cubic spline
  through knots 20 s apart (correlation 1/e at about 14 s, slightly negative beyond
  25 s; RMS about 0.94 sigma): not the fit's model.

``+ mount``: the GM 15 s errors, and each run the mount given to the synchronisation
is off by a new draw of N(0, sigma) per value (lever arm 2 cm, boresight 0.2 deg,
latency 1 ms: a taped lever arm and a boresight from a patch test), ``stated``: with
those sigma in its ``[uncertainty]`` (`kinsync.sync.mount_effect` adds them), ``exact``:
without (the sigma before, which held none of the mount's error).

``tau_c`` is the correlation time the fit assumes (``position_corr_time_s``): the
default 15 s, or 0, the model before issue item 8 (errors independent between
sightings, weighted least squares; the same figures as the code before the change).

Drives (25 Hz records, 50-100 deg field of view, to keep runs short):

* ``pairs``: the 80 s figure-eight; sync points S1 and S2 are passed 2.6 s apart on
  each of two passes, each with a twin 2.5 m farther out seen at the same instant:
  eight sightings in two bursts (several sync points passed on one pass);
* ``loop``: the same without the twins, four sightings;
* ``oval``: 120 s oval, sync points 5 m from the start and the end: eight sightings,
  several 5-15 s apart, some on opposite headings.

Columns: RMS error / RMS sigma and their ratio for t0 (profile 0), T, the clock at
the middle and at the last profile. ``--ins N`` adds N runs of the end-to-end demo's
chain (`kinsync.demo.end_to_end_chain`: navigation IMU and white RTK GNSS noise
through the INS filter and smoother, errors of 1-2 mm correlated over about 6 s;
Method B on that trajectory with the smoother's horizontal sigma), about 2 s a run.
There the trajectory part is no larger than the scan part, so these rows also carry
what the position model leaves out: the sphere fits' own sigma (t0 and T are 1.4
times their sigma on that survey's exact trajectory), the smoother's sigma (East
error 1.3 times its reported sigma) and attitude errors.
Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_sync_sigma.py [runs]
[--ins N]``).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import KinsyncWarning
from kinsync.mount import Mount, MountUncertainty
from kinsync.sim.nav_noise import gauss_markov_trajectory, noisy_trajectory
from kinsync.sim.profiler import (
    DriveScanConfig,
    DriveScanSimulation,
    ProfilerConfig,
    profiles_near_targets,
    simulate_drive_scan,
    simulate_profiler,
)
from kinsync.sim.scene import Scene, SceneLayout, trajectory_to_local
from kinsync.sync.config import ObjectSpaceConfig
from kinsync.sync.object_space import ObjectSpaceResult, synchronise_object_space
from kinsync.sync.scan import SyncPoints

NOISE_M = 0.02
RUNS = 200
DEFAULT_TAU_S = ObjectSpaceConfig().position_corr_time_s

DRIVES: dict[str, dict[str, object]] = {
    "pairs": {"route": "loop", "duration_s": 80.0},
    "loop": {"route": "loop", "duration_s": 80.0},
    "oval": {"duration_s": 120.0, "layout": SceneLayout(n_control=0, sync_lead_m=5.0)},
}
# (label, generator, its correlation time or knot spacing (s), tau_c the fit assumes)
CASES = [
    ("GM 15 s", "gm", 15.0, DEFAULT_TAU_S),
    ("GM 15 s", "gm", 15.0, 0.0),
    ("spline 20 s", "spline", 20.0, DEFAULT_TAU_S),
    ("GM 5 s", "gm", 5.0, DEFAULT_TAU_S),
    ("GM 40 s", "gm", 40.0, DEFAULT_TAU_S),
    ("GM 0.3 s", "gm", 0.3, DEFAULT_TAU_S),
    ("GM 0.3 s", "gm", 0.3, 0.0),
]
UNITS = np.array([1e3, 1e6, 1e3, 1e3])  # ms, us, ms, ms
MOUNT_STD = MountUncertainty(
    lever_arm_body_m=(0.02, 0.02, 0.02), boresight_rpy_deg=(0.2, 0.2, 0.2), latency_s=0.001
)
MOUNT_CASES = ("stated", "exact")


@dataclasses.dataclass(frozen=True, eq=False)
class Setup:
    """A drive's truth and mount (the simulation), its scene and sync points."""

    sim: DriveScanSimulation
    scene: Scene
    sync_points: SyncPoints


def _outer_twins(sim: DriveScanSimulation, offset_m: float) -> Scene:
    """The scene with a second sync target ``offset_m`` farther out beside each one."""
    pos, _ = trajectory_to_local(sim.truth_trajectory, sim.scene.origin_lat_lon_h)
    twins = []
    for target in sim.scene.targets_of_kind("sync"):
        c = np.array(target.centre_ned_m)
        k = int(np.argmin(np.hypot(*(pos[:, :2] - c[:2]).T)))
        out = (c[:2] - pos[k, :2]) / np.hypot(*(c[:2] - pos[k, :2]))
        centre = (c[0] + offset_m * out[0], c[1] + offset_m * out[1], c[2])
        twins.append(dataclasses.replace(target, name=target.name + "b", centre_ned_m=centre))
    return dataclasses.replace(sim.scene, targets=sim.scene.targets + tuple(twins))


@functools.cache
def drive(name: str) -> Setup:
    """The drive's truth and scene (built once per worker)."""
    base = DriveScanConfig(
        rate_hz=25.0,
        near_targets_only=True,
        profiler=ProfilerConfig(range_noise_m=0.003, angle_min_deg=50.0, angle_max_deg=100.0),
        layout=SceneLayout(n_control=0),
    )
    sim = simulate_drive_scan(dataclasses.replace(base, **DRIVES[name]))  # type: ignore[arg-type]
    scene = _outer_twins(sim, 2.5) if name == "pairs" else sim.scene
    sync = scene.targets_of_kind("sync")
    points = SyncPoints(tuple(t.name for t in sync), scene.target_lat_lon_h(sync))
    return Setup(sim, scene, points)


def _errors(
    r: ObjectSpaceResult, t0_s: float, period_s: float, n_profiles: int
) -> tuple[FloatArray, FloatArray]:
    """Errors and sigmas of (t0, T, clock mid-scan, clock at the last profile)."""
    n = np.array([n_profiles / 2.0, n_profiles - 1.0])
    t_err = (r.t0_s - t0_s) + n * (r.period_s - period_s)
    err = np.array([r.t0_s - t0_s, r.period_s - period_s, *t_err])
    sig = np.array([r.t0_std_s, r.period_std_s, *r.time_std_s(n)])
    return err, sig


def _mount_off(mount: Mount, run: int, stated: bool) -> Mount:
    """``mount`` off by a draw of N(0, `MOUNT_STD`) per value, with that sigma if stated."""
    rng = np.random.default_rng([run, 11])
    assert MOUNT_STD.lever_arm_body_m is not None
    assert MOUNT_STD.boresight_rpy_deg is not None
    assert MOUNT_STD.latency_s is not None
    lever = np.add(mount.lever_arm_body_m, rng.normal(0.0, MOUNT_STD.lever_arm_body_m))
    rpy = np.add(mount.boresight_rpy_deg, rng.normal(0.0, MOUNT_STD.boresight_rpy_deg))
    return dataclasses.replace(
        mount,
        lever_arm_body_m=(float(lever[0]), float(lever[1]), float(lever[2])),
        boresight_rpy_deg=(float(rpy[0]), float(rpy[1]), float(rpy[2])),
        latency_s=mount.latency_s + float(rng.normal(0.0, MOUNT_STD.latency_s)),
        uncertainty=MOUNT_STD if stated else None,
    )


def one_run(
    name: str, generator: str, corr_s: float, tau_c: float, run: int, mount_case: str = ""
) -> tuple[FloatArray, FloatArray]:
    """Errors and reported sigmas of (t0, T, t mid-scan, t last profile) for one run."""
    setup = drive(name)
    sim = setup.sim
    rng = np.random.default_rng([run, 7])
    t0 = sim.truth["t0_s"] + rng.uniform(0.0, sim.config.period_s)
    period = sim.config.period_s
    cfg = dataclasses.replace(sim.config.profiler, t0_s=t0, seed=1000 + run, period_s=period)
    mount = sim.config.mount
    wanted = profiles_near_targets(sim.truth_trajectory, mount, setup.scene, cfg, t0)
    scan = simulate_profiler(sim.truth_trajectory, mount, setup.scene, cfg, profiles=wanted)
    if generator == "gm":
        traj = gauss_markov_trajectory(
            sim.truth_trajectory, std_m=NOISE_M, corr_time_s=corr_s, seed=500 + run
        )
    else:
        traj = noisy_trajectory(
            sim.truth_trajectory,
            std_pos_ned_m=(NOISE_M, NOISE_M, NOISE_M),
            std_att_deg=(0.0, 0.0, 0.0),
            corr_time_s=corr_s,
            seed=500 + run,
        )
    ocfg = ObjectSpaceConfig(position_std_m=NOISE_M, position_corr_time_s=tau_c)
    given = _mount_off(mount, run, mount_case == "stated") if mount_case else mount
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", KinsyncWarning)  # the mount taken as exact
        r = synchronise_object_space(scan.scan, traj, given, setup.sync_points, ocfg)
    return _errors(r, t0, period, scan.n_profiles)


def ins_run(seed: int) -> list[tuple[FloatArray, FloatArray]]:
    """One end-to-end survey and INS/GNSS chain; Method B with tau_c default and 0."""
    from kinsync.demo.end_to_end_chain import run_chain  # noqa: PLC0415
    from kinsync.demo.end_to_end_survey import EndToEndConfig, simulate_survey  # noqa: PLC0415

    survey = simulate_survey(EndToEndConfig(seed=seed))
    chain = run_chain(survey)
    assert chain.ins.smoothed is not None
    std_m = float(np.sqrt(np.mean(chain.ins.smoothed.std_pos_ned_m[:, :2] ** 2)))
    t0 = survey.scan.t0_s
    out = []
    for tau in (DEFAULT_TAU_S, 0.0):
        cfg = ObjectSpaceConfig(position_std_m=std_m, position_corr_time_s=tau)
        r = synchronise_object_space(
            survey.scan.scan, chain.trajectory, survey.mount, survey.sync_points, cfg
        )
        out.append(_errors(r, t0, survey.scan.period_s, survey.scan.n_profiles))
    return out


def _star(args: tuple[str, str, float, float, int, str]) -> tuple[FloatArray, FloatArray]:
    return one_run(*args)


def _row(drive_name: str, label: str, tau: float, out: list[tuple[FloatArray, FloatArray]]) -> str:
    err = np.array([e for e, _ in out])
    sig = np.array([s for _, s in out])
    rms_e = np.sqrt(np.mean(err**2, axis=0)) * UNITS
    rms_s = np.sqrt(np.mean(sig**2, axis=0)) * UNITS
    cells = "".join(
        f"{f'{e:.3g}/{s:.3g}':>{w}}{e / s:>7.2f}"
        for e, s, w in zip(rms_e, rms_s, (17, 18, 15, 15), strict=True)
    )
    return f"{drive_name:<7}{label:<16}{tau:>6g}{cells}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="?", type=int, default=RUNS, help="runs a row (0: none)")
    parser.add_argument("--ins", type=int, default=0, help="runs of the INS/GNSS chain")
    parser.add_argument(
        "--mount-only", action="store_true", help="only the rows with the mount's errors"
    )
    args = parser.parse_args()
    print(f"Method B Monte Carlo, {args.runs} runs a row, {NOISE_M * 100:g} cm isotropic errors")
    print(
        f"{'drive':<7}{'errors':<16}{'tau_c':>6}{'t0 (ms)':>17}{'ratio':>7}{'T (us)':>18}"
        f"{'ratio':>7}{'mid (ms)':>15}{'ratio':>7}{'last (ms)':>15}{'ratio':>7}"
    )
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        for name in DRIVES if args.runs > 0 else ():
            cases = [(*case, "") for case in CASES if not args.mount_only]
            cases += [("+ mount " + m, "gm", 15.0, DEFAULT_TAU_S, m) for m in MOUNT_CASES]
            for label, generator, corr_s, tau_c, mount_case in cases:
                jobs = [
                    (name, generator, corr_s, tau_c, run, mount_case) for run in range(args.runs)
                ]
                print(_row(name, label, tau_c, list(pool.map(_star, jobs, chunksize=8))))
        if args.ins > 0:
            ins = list(pool.map(ins_run, range(1, args.ins + 1)))
            for k, tau in enumerate((DEFAULT_TAU_S, 0.0)):
                print(_row("INS", f"{args.ins} chains", tau, [o[k] for o in ins]))
    se = 1.0 / math.sqrt(2.0 * max(args.runs, args.ins, 1))
    elapsed = time.perf_counter() - start
    print(
        f"(RMS error / RMS sigma; sampling error of a ratio about {se:.2f} x it; {elapsed:.0f} s)"
    )


if __name__ == "__main__":
    main()
