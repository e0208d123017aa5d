"""PPS + ZDA log simulator: a drifting acquisition clock tagging a GNSS receiver's output.

The simulation follows the acquisition chain, so the clock model enters the logs the
way it does on a real system (SPEC section 6):

1. **True edges.** The receiver's pulse per second rises at whole GPS seconds
   ``G_k = g0 + k``, ``k = 0 .. n - 1`` with ``n = floor(duration_s) + 1`` and ``g0`` the
   GPS time of ``start_utc`` (a whole UTC second; GPS = UTC + 18 s in 2026).
2. **Local clock.** The acquisition computer's clock reads
   ``t_local(g) = l0 + (g - g0) / (1 + drift_ppm * 1e-6)`` at GPS time ``g``, with
   ``l0 = g0 - offset_s``; so the exact mapping back is the `kinsync.clock.ClockModel`
   ``g = g0 + (t_local - l0) * (1 + drift_ppm * 1e-6)`` with ``reference_local_s = l0``,
   ``reference_gps_s = g0`` (``drift_ppm > 0``: the local clock runs slow).
3. **Edge detection.** Each edge is tagged at ``t_local(G_k)`` plus Gaussian jitter
   (``jitter_us``, 1 sigma). ``missing`` edges (never the first or last) are not
   detected; ``spurious`` extra edges are tagged at random times 50-950 ms after a
   true edge (noise on the PPS line).
4. **Serial output.** ``zda_delay_ms`` after each edge the receiver starts a burst on
   its serial line (8N1 at ``baud``): ZDA, then GGA, RMC and HDT back to back, each
   taking ``(len + 2) * 10 / baud`` s. With the ``"preceding"`` convention the ZDA
   names the edge just passed; with ``"following"`` the next edge (a burst also goes
   out before the first edge, so every edge is named exactly once). GGA and RMC carry
   the time of the edge just passed.
5. **Arrival tags.** The acquisition software tags each sentence at the end of its
   reception, ``t_local`` of that instant plus Gaussian jitter
   (``arrival_jitter_us``). ``bad_zda`` ZDAs (of detected edges) name a second one off
   the truth; ``bad_lines`` GGA/RMC/HDT lines are corrupted on the line (alternately a
   wrong checksum and a sentence cut short).

Expected fit: ``n_missing = missing``, ``n_spurious = spurious``, ``n_wrong_zda =
bad_zda``, ``n_rejected_messages = bad_lines + bad_zda + missing`` (the ZDA of a missing
edge has no pulse to pair with).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from kinsync._typing import ArrayLike, FloatArray, IntArray
from kinsync._validate import finite_number, positive_number
from kinsync.budget import serial_transmission_time_s
from kinsync.clock import CLOCK_FORMULA, CONVENTIONS, Convention, gps_to_utc_posix_s, utc_to_gps_s
from kinsync.errors import InputError
from kinsync.io.atomic import atomic_path, atomic_write_text
from kinsync.io.nmea import format_sentence
from kinsync.io.tables import write_numeric_csv
from kinsync.sim.folder import simulation_folder

__all__ = [
    "MIN_DURATION_S",
    "ClockSimConfig",
    "ClockSimulation",
    "simulate_clock",
    "write_clock_simulation",
]

_SPURIOUS_PHASE_S = (0.05, 0.95)
_MAX_BURST_END_S = 0.95
_MIN_EDGES = 10
MIN_DURATION_S = float(_MIN_EDGES - 1)
"""Shortest log simulated (s): ``floor(duration_s) + 1`` edges, at least 10 of them."""
_LAT_DDMM = "4648.8130"
_LON_DDDMM = "07112.4925"


def _spurious_pulses(
    rng: np.random.Generator,
    edges_gps: FloatArray,
    local: Callable[[FloatArray], FloatArray],
    count: int,
    real_local: FloatArray,
) -> FloatArray:
    """Local times of ``count`` spurious edges, distinct from each other and the real ones.

    Each falls at a random time 50-950 ms after a random true edge. Many of them in a
    short log can round to the same float of local time (about 0.24 us apart at 1.5e9 s),
    and a PPS log with a repeated time is refused by `read_pps_csv`: such draws are drawn
    again, so the simulator never writes a log its own reader refuses.
    """
    spur = np.empty(0)
    while len(spur) < count:
        k = rng.integers(0, len(edges_gps) - 1, size=count - len(spur))
        new = local(edges_gps[k] + rng.uniform(*_SPURIOUS_PHASE_S, size=len(k)))
        spur = np.unique(np.concatenate([spur, new]))  # sorted, repeats dropped
        spur = spur[~np.isin(spur, real_local)]
    return np.asarray(spur, dtype=np.float64)


def _check(condition: bool, message: str) -> None:
    if not condition:
        raise InputError(f"clock simulation: {message}")


def _count(value: int, name: str) -> int:
    _check(
        not isinstance(value, bool) and int(value) == value and value >= 0,
        f"{name} must be a non-negative whole number, got {value!r}",
    )
    return int(value)


@dataclass(frozen=True)
class ClockSimConfig:
    """Set-up of a simulated PPS + NMEA log (defaults: the issue's scenario).

    Attributes
    ----------
    offset_s : float
        ``reference_gps_s - reference_local_s`` at the first edge (s).
    drift_ppm : float
        Local clock rate error (ppm); > 0: the local clock runs slow.
    jitter_us : float
        PPS edge detection jitter, 1 sigma (us), >= 0.
    duration_s : float
        Log length (s), >= 9; ``floor(duration_s) + 1`` edges.
    missing, spurious, bad_zda, bad_lines : int
        Undetected edges, extra edges, ZDAs naming a wrong second, corrupted non-ZDA
        lines.
    seed : int
        Seed of the random generator (same seed, same logs).
    baud : float
        Serial line rate (bit/s), 8N1.
    zda_delay_ms : float
        Time from an edge to the start of the burst that follows it (ms), > 0.
    convention : {"preceding", "following"}
        Which edge a ZDA names.
    start_utc : str
        UTC of the first edge, ISO 8601 whole second (``2026-11-22T12:00:00``).
    arrival_jitter_us : float
        Jitter of the software's arrival tags, 1 sigma (us), >= 0.
    """

    offset_s: float = 0.37
    drift_ppm: float = 25.0
    jitter_us: float = 1.0
    duration_s: float = 600.0
    missing: int = 3
    spurious: int = 2
    bad_zda: int = 1
    bad_lines: int = 2
    seed: int = 1
    baud: float = 115200.0
    zda_delay_ms: float = 15.0
    convention: Convention = "preceding"
    start_utc: str = "2026-11-22T12:00:00"
    arrival_jitter_us: float = 50.0

    def __post_init__(self) -> None:
        finite_number(self.offset_s, "clock simulation: offset_s")
        drift = finite_number(self.drift_ppm, "clock simulation: drift_ppm")
        _check(abs(drift) < 1e4, f"drift_ppm must be within +-10000 ppm, got {drift}")
        for name in ("jitter_us", "arrival_jitter_us"):
            value = finite_number(getattr(self, name), f"clock simulation: {name}")
            _check(value >= 0.0, f"{name} must be >= 0, got {value}")
        duration = finite_number(self.duration_s, "clock simulation: duration_s")
        _check(
            duration >= MIN_DURATION_S,
            f"duration_s must be at least {MIN_DURATION_S:g} s, got {duration}",
        )
        for name in ("missing", "spurious", "bad_zda", "bad_lines", "seed"):
            _count(getattr(self, name), name)
        positive_number(self.baud, "clock simulation: baud")
        positive_number(self.zda_delay_ms, "clock simulation: zda_delay_ms")
        _check(
            self.convention in CONVENTIONS,
            f"convention must be preceding or following, got {self.convention!r}",
        )
        n = self.n_edges
        _check(
            self.missing + self.bad_zda <= n - 2,
            f"{self.missing} missing + {self.bad_zda} bad ZDA edges do not fit among the "
            f"{n - 2} interior edges of a {duration:g} s log",
        )
        _check(
            self.bad_lines <= 3 * n,
            f"bad_lines {self.bad_lines} exceeds the {3 * n} GGA/RMC/HDT lines",
        )
        _ = self.start_gps_s  # validates start_utc

    @property
    def n_edges(self) -> int:
        """True PPS edges in the log."""
        return math.floor(self.duration_s) + 1

    @property
    def start_gps_s(self) -> float:
        """GPS time of the first edge (whole second)."""
        try:
            when = datetime.fromisoformat(self.start_utc)
        except (TypeError, ValueError) as err:
            msg = f"clock simulation: start_utc {self.start_utc!r} is not an ISO 8601 time"
            raise InputError(msg) from err
        if when.tzinfo is None:
            when = when.replace(tzinfo=UTC)
        posix = when.timestamp()
        _check(posix == math.floor(posix), f"start_utc must be a whole second: {self.start_utc}")
        return float(utc_to_gps_s(posix))


@dataclass(frozen=True, eq=False)
class ClockSimulation:
    """A simulated PPS log and NMEA log with their ground truth.

    Attributes
    ----------
    config : ClockSimConfig
    pps_t_local_s : ndarray, shape (N,)
        Detected edges (s, local clock), increasing: ``pps.csv``.
    nmea_t_local_s : ndarray, shape (L,)
        Arrival time of each NMEA line (s, local clock), increasing.
    nmea_sentences : tuple of str, length L
        The lines as received (``$...*hh``; corrupted ones included): ``nmea.csv``.
    zda_t_local_s, zda_gps_s, zda_n_bytes : ndarray, shape (M,)
        Every ZDA's arrival time, the GPS second it names and its bytes on the wire
        (``len + 2``): the arrays `kinsync.clock.fit_clock` takes.
    truth : dict
        Ground truth, as written to ``truth.json``.
    """

    config: ClockSimConfig
    pps_t_local_s: FloatArray
    nmea_t_local_s: FloatArray
    nmea_sentences: tuple[str, ...]
    zda_t_local_s: FloatArray
    zda_gps_s: FloatArray
    zda_n_bytes: IntArray
    truth: dict[str, Any]

    def true_gps_s(self, t_local_s: ArrayLike) -> FloatArray:
        """Exact GPS time of local clock readings (the true clock model)."""
        t = np.asarray(t_local_s, dtype=np.float64)
        c = self.config
        g0 = c.start_gps_s
        return np.asarray(g0 + (t - (g0 - c.offset_s)) * (1.0 + c.drift_ppm * 1e-6))

    def true_local_s(self, t_gps_s: ArrayLike) -> FloatArray:
        """Local clock reading at GPS times (noise-free)."""
        g = np.asarray(t_gps_s, dtype=np.float64)
        c = self.config
        g0 = c.start_gps_s
        return np.asarray((g0 - c.offset_s) + (g - g0) / (1.0 + c.drift_ppm * 1e-6))


def _utc_fields(t_gps_s: float) -> tuple[str, str, tuple[int, int, int]]:
    """(hhmmss.ss, ddmmyy, (day, month, year)) of a GPS time; 23:59:60 in a leap second."""
    posix = gps_to_utc_posix_s(t_gps_s)
    # Inside an inserted leap second the POSIX time is the next 00:00:00 (which has its
    # own GPS second): the receiver sends 23:59:60 of the day before.
    leap = float(utc_to_gps_s(posix)) != t_gps_s
    when = datetime.fromtimestamp(posix - 1.0 if leap else posix, tz=UTC)
    second = 60 if leap else when.second
    hms = f"{when.hour:02d}{when.minute:02d}{second:02d}.00"
    return (
        hms,
        f"{when.day:02d}{when.month:02d}{when.year % 100:02d}",
        (
            when.day,
            when.month,
            when.year,
        ),
    )


def _burst(
    edge_gps_s: float, named_gps_s: float, rng: np.random.Generator
) -> list[tuple[str, str]]:
    """(kind, sentence) of the burst after an edge: ZDA naming ``named_gps_s``, GGA, RMC, HDT."""
    zhms, _, (zd, zm, zy) = _utc_fields(named_gps_s)
    hms, ddmmyy, _ = _utc_fields(edge_gps_s)
    alt = 23.45 + float(rng.normal(0.0, 0.01))
    heading = 87.3 + float(rng.normal(0.0, 0.05))
    return [
        ("ZDA", format_sentence(f"GPZDA,{zhms},{zd:02d},{zm:02d},{zy:04d},00,00")),
        (
            "GGA",
            format_sentence(
                f"GPGGA,{hms},{_LAT_DDMM},N,{_LON_DDDMM},W,4,14,0.7,{alt:.2f},M,-28.91,M,1.0,0101"
            ),
        ),
        (
            "RMC",
            format_sentence(
                f"GPRMC,{hms},A,{_LAT_DDMM},N,{_LON_DDDMM},W,0.02,{heading:.1f},{ddmmyy},14.8,W,D"
            ),
        ),
        ("HDT", format_sentence(f"HEHDT,{heading:.2f},T")),
    ]


def _corrupt(sentence: str, i: int) -> str:
    """A wrong checksum (even i) or a sentence cut short (odd i)."""
    if i % 2 == 0:
        body, _, given = sentence[1:].rpartition("*")
        wrong = (int(given, 16) ^ 0x01) & 0xFF
        return f"${body}*{wrong:02X}"
    return sentence[: len(sentence) // 2]


def _serial_bursts(
    c: ClockSimConfig, wrong_by: dict[int, int], rng: np.random.Generator
) -> tuple[list[float], list[str], list[str], list[float], dict[int, float]]:
    """Send time (GPS), sentence and kind of every line; ZDA named seconds; wrong ZDAs.

    Bursts go out after edge k for k in 0..n-1 (``"preceding"``: the ZDA names k) or
    k in -1..n-2 (``"following"``: it names k + 1), so every edge is named once. The
    send time of a line is the end of its transmission.
    """
    g0 = c.start_gps_s
    first_k = -1 if c.convention == "following" else 0
    shift = 1 if c.convention == "following" else 0
    times_gps: list[float] = []
    sentences: list[str] = []
    kinds: list[str] = []
    zda_named: list[float] = []
    wrong_true: dict[int, float] = {}  # sentence index -> true GPS second of its edge
    longest_burst = 0.0
    for k in range(first_k, first_k + c.n_edges):
        edge = g0 + k
        named_k = k + shift
        named = g0 + named_k + wrong_by.get(named_k, 0)
        t_send = edge + c.zda_delay_ms * 1e-3
        for kind, sentence in _burst(edge, named, rng):
            t_send += serial_transmission_time_s(len(sentence) + 2, c.baud)
            if kind == "ZDA":
                zda_named.append(named)
                if named_k in wrong_by:
                    wrong_true[len(sentences)] = g0 + named_k
            times_gps.append(t_send)
            sentences.append(sentence)
            kinds.append(kind)
        longest_burst = max(longest_burst, t_send - edge)
    _check(
        longest_burst < _MAX_BURST_END_S,
        f"the burst after an edge ends {longest_burst:.3f} s after it at {c.baud:g} baud "
        "with the ZDA delay: it must end within 0.95 s; raise --baud or lower --zda-delay-ms",
    )
    return times_gps, sentences, kinds, zda_named, wrong_true


def simulate_clock(config: ClockSimConfig | None = None) -> ClockSimulation:
    """Simulate PPS and NMEA logs of a drifting acquisition clock (module docstring).

    Parameters
    ----------
    config : ClockSimConfig, optional
        Set-up; the issue's scenario by default.

    Returns
    -------
    ClockSimulation

    Raises
    ------
    InputError
        An invalid set-up, or a burst that does not fit in one second at the baud.
    """
    c = config or ClockSimConfig()
    rng = np.random.default_rng(c.seed)
    g0 = c.start_gps_s
    n = c.n_edges
    d = c.drift_ppm * 1e-6
    l0 = g0 - c.offset_s

    def local(g: FloatArray) -> FloatArray:
        return np.asarray(l0 + (g - g0) / (1.0 + d))

    edges_gps = g0 + np.arange(n, dtype=np.float64)
    edges_local = local(edges_gps)
    detected = edges_local + rng.normal(0.0, c.jitter_us * 1e-6, n)
    interior = np.arange(1, n - 1)
    chosen = rng.choice(interior, size=c.missing + c.bad_zda, replace=False)
    missing_k = np.sort(chosen[: c.missing])
    bad_zda_k = np.sort(chosen[c.missing :])
    keep = np.ones(n, dtype=np.bool_)
    keep[missing_k] = False
    spur_local = _spurious_pulses(rng, edges_gps, local, c.spurious, detected[keep])
    pps = np.sort(np.concatenate([detected[keep], spur_local]))

    wrong_by = {int(k): int(rng.choice([-1, 1])) for k in bad_zda_k}
    times_gps, sentences, kinds, zda_named, wrong_true = _serial_bursts(c, wrong_by, rng)
    arrival = local(np.asarray(times_gps)) + rng.normal(
        0.0, c.arrival_jitter_us * 1e-6, len(times_gps)
    )
    is_zda = np.array([k == "ZDA" for k in kinds])
    others = np.flatnonzero(~is_zda)
    bad_idx = np.sort(rng.choice(others, size=c.bad_lines, replace=False))
    for j, i in enumerate(bad_idx):
        sentences[i] = _corrupt(sentences[i], j)
    # Lines in arrival order (line 1 of nmea.csv is the header).
    order = np.argsort(arrival, kind="stable")
    line_of = np.empty(len(order), dtype=np.int64)
    line_of[order] = np.arange(len(order)) + 2
    bad_lines_doc = [
        {
            "t_local_s": float(arrival[i]),
            "line": int(line_of[i]),
            "kind": "bad checksum" if j % 2 == 0 else "truncated",
            "sentence": sentences[i],
        }
        for j, i in enumerate(bad_idx)
    ]
    wrong_doc = [
        {
            "t_local_s": float(arrival[i]),
            "line": int(line_of[i]),
            "named_gps_s": zda_named[int(np.count_nonzero(is_zda[:i]))],
            "true_gps_s": true_gps,
        }
        for i, true_gps in sorted(wrong_true.items())
    ]
    zda_t = arrival[is_zda]
    zda_bytes = np.array([len(s) + 2 for s, z in zip(sentences, is_zda, strict=True) if z])
    truth = {
        "formula": CLOCK_FORMULA,
        "local_clock": "t_local_s = reference_local_s + (t_gps_s - reference_gps_s) / "
        "(1 + drift_ppm * 1e-6)",
        "offset_s": c.offset_s,
        "drift_ppm": c.drift_ppm,
        "reference_local_s": l0,
        "reference_gps_s": g0,
        "start_utc": c.start_utc,
        "config": asdict(c),
        "n_edges": n,
        "edges_gps_s": edges_gps.tolist(),
        "edges_t_local_s": edges_local.tolist(),
        "missing_gps_s": (g0 + missing_k).astype(np.float64).tolist(),
        "spurious_t_local_s": spur_local.tolist(),
        "wrong_zda": wrong_doc,
        "bad_lines": bad_lines_doc,
        "n_missing": c.missing,
        "n_spurious": c.spurious,
        "n_wrong_zda": c.bad_zda,
        "n_bad_lines": c.bad_lines,
        "n_rejected_messages": c.bad_lines + c.bad_zda + c.missing,
        "n_pulses": len(pps) - c.spurious,
    }
    return ClockSimulation(
        config=c,
        pps_t_local_s=pps,
        nmea_t_local_s=arrival[order],
        nmea_sentences=tuple(sentences[i] for i in order),
        zda_t_local_s=zda_t,
        zda_gps_s=np.asarray(zda_named, dtype=np.float64),
        zda_n_bytes=zda_bytes.astype(np.int64),
        truth=truth,
    )


def write_clock_simulation(sim: ClockSimulation, folder: Path) -> None:
    """Write ``pps.csv``, ``nmea.csv`` and ``truth.json`` into ``folder`` (created if missing).

    ``pps.csv`` has the column ``t_local_s``; ``nmea.csv`` the columns
    ``t_local_s,sentence`` with the sentence CSV-quoted (it holds commas). Each file
    appears only when complete.

    Raises
    ------
    InputError
        ``folder`` is an existing file.
    """
    with simulation_folder(folder, "clock") as out:
        write_numeric_csv(out / "pps.csv", {"t_local_s": sim.pps_t_local_s})
        with (
            atomic_path(out / "nmea.csv") as tmp,
            tmp.open("w", encoding="ascii", newline="") as fh,
        ):
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(["t_local_s", "sentence"])
            for t, sentence in zip(sim.nmea_t_local_s.tolist(), sim.nmea_sentences, strict=True):
                writer.writerow([repr(t), sentence])
        atomic_write_text(out / "truth.json", json.dumps(sim.truth, indent=2) + "\n")
