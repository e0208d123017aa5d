"""PPS + ZDA clock fit: time and accuracy on long logs, against a plain least-squares line.

The baseline is ``np.polyfit`` of GPS second against local time, given the pulses
already labelled with their true second (what a hand-made script does once the
pairing is done), on the same log with its faults: one spurious pulse is enough to
spoil it. kinsync pairs, labels, rejects and fits by itself.
Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_clock.py``).
"""

from __future__ import annotations

import time

import numpy as np

from kinsync.clock import fit_clock
from kinsync.sim.clock import ClockSimConfig, simulate_clock


def main() -> None:
    print(
        f"{'log':>8}{'pulses':>8}{'faults m/s/z':>14}{'fit (ms)':>10}"
        f"{'drift err (ppm)':>17}{'max map err (us)':>18}{'polyfit max err (us)':>22}"
    )
    for hours in (0.17, 1.0, 6.0, 24.0):
        cfg = ClockSimConfig(duration_s=hours * 3600.0, missing=30, spurious=20, bad_zda=5, seed=2)
        sim = simulate_clock(cfg)
        t0 = time.perf_counter()
        fit = fit_clock(sim.pps_t_local_s, sim.zda_t_local_s, sim.zda_gps_s, sim.zda_n_bytes)
        elapsed = time.perf_counter() - t0
        edges_local = np.asarray(sim.truth["edges_t_local_s"])
        edges_gps = np.asarray(sim.truth["edges_gps_s"])
        err = fit.model.apply(edges_local) - edges_gps
        # Baseline: every detected pulse labelled with the nearest true second.
        labels = np.round(sim.true_gps_s(sim.pps_t_local_s))
        coef = np.polyfit(sim.pps_t_local_s - sim.pps_t_local_s[0], labels, 1)
        base = np.polyval(coef, edges_local - sim.pps_t_local_s[0]) - edges_gps
        drift_err = fit.model.drift_ppm - cfg.drift_ppm
        faults = f"{fit.n_missing}/{fit.n_spurious}/{fit.n_wrong_zda}"
        print(
            f"{hours:>7g}h{len(sim.pps_t_local_s):>8}{faults:>14}{elapsed * 1e3:>10.1f}"
            f"{drift_err:>17.2e}{np.abs(err).max() * 1e6:>18.3f}"
            f"{np.abs(base).max() * 1e6:>22.1f}"
        )


if __name__ == "__main__":
    main()
