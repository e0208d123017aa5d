"""PPS + ZDA clock fit: time and accuracy on long logs, against a plain least-squares line.

The baseline is ``np.polyfit`` of GPS second against local time, given the pulses
already labelled with their true second (what a hand-made script does once the
pairing is done), on the same log with its faults: one spurious pulse is enough to
spoil it. kinsync pairs, labels, rejects and fits by itself.

Then ``clock apply`` on CSV files of 0.25, 1 and 4 million rows (a local-time column,
an id, a text label and two numbers), kinsync's streamed pipeline
(`kinsync.io.tables.read_time_column`, the model, `kinsync.pipelines.clock_apply`)
against the straightforward Python script it replaced: ``csv`` rows read into lists,
the column converted with ``float``, every row written back with ``repr`` of its GPS
time (what ``clock apply`` did before, keeping about 15 times the file in memory).
Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_clock.py [--rows 250000,...]``).
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

import numpy as np

from kinsync.clock import ClockModel, fit_clock
from kinsync.io.tables import read_time_column
from kinsync.pipelines.clock_apply import write_with_gps_time
from kinsync.sim.clock import ClockSimConfig, simulate_clock

MODEL = ClockModel(
    reference_local_s=1000.0, reference_gps_s=1.4e9, drift_ppm=25.0, span_local_s=(0.0, 1e5)
)


def _write_table(path: Path, rows: int) -> None:
    """A CSV with a local-time column and others, written in blocks."""
    rng = np.random.default_rng(1)
    with path.open("w") as fh:
        fh.write("id,t_local_s,label,x_m,y_m\n")
        for start in range(0, rows, 100_000):
            n = min(100_000, rows - start)
            t = (1000.0 + (start + np.arange(n)) * 1e-3).tolist()
            xy = rng.normal(size=(n, 2))
            fh.writelines(
                f"{start + i},{t[i]!r},wall {i % 7},{xy[i, 0]:.4f},{xy[i, 1]:.4f}\n"
                for i in range(n)
            )


def _plain_script(src: Path, out: Path) -> None:
    """The baseline: every row kept as Python strings, written back with the new column."""
    with src.open(newline="") as fh:
        rows = list(csv.reader(fh))
    col = rows[0].index("t_local_s")
    t = MODEL.apply(np.array([float(r[col]) for r in rows[1:]]))
    with out.open("w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow([*rows[0], "t_gps_s"])
        for row, value in zip(rows[1:], t.tolist(), strict=True):
            writer.writerow([*row, repr(value)])


def apply_figures(sizes: list[int]) -> None:
    """Time ``clock apply``'s pipeline against the plain script on growing files."""
    print(f"\n{'rows':>10}{'MB':>8}{'kinsync (s)':>13}{'plain csv (s)':>15}{'ratio':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        for rows in sizes:
            src = Path(tmp) / "in.csv"
            _write_table(src, rows)
            t0 = time.perf_counter()
            t_local, _ = read_time_column(src, "t_local_s")
            write_with_gps_time(src, Path(tmp) / "a.csv", "t_gps_s", MODEL.apply(t_local))
            ours = time.perf_counter() - t0
            t0 = time.perf_counter()
            _plain_script(src, Path(tmp) / "b.csv")
            plain = time.perf_counter() - t0
            mb = src.stat().st_size / 1e6
            print(f"{rows:>10,}{mb:>8.0f}{ours:>13.2f}{plain:>15.2f}{plain / ours:>7.1f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default="250000,1000000,4000000", help="clock apply sizes")
    args = parser.parse_args()
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
    apply_figures([int(n) for n in args.rows.split(",")])


if __name__ == "__main__":
    main()
