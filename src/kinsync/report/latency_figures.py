"""Figures of Method A: latency per rate, centre separations, and the planner."""

from __future__ import annotations

import math

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from kinsync._text import counted
from kinsync.latency.planning import LatencyPlan
from kinsync.latency.sphere import SphereLatencyResult
from kinsync.report.figures import png_bytes
from kinsync.report.style import report_figure

__all__ = ["latency_per_rate_figure", "plan_figure"]


@report_figure
def latency_per_rate_figure(
    result: SphereLatencyResult, truth_latency_s: float | None = None
) -> bytes:
    """Latency per rate with 1-sigma bars, the combined estimate, and the centre shifts.

    Left: tau per rate (exact model, bars) and the first-order formula (crosses), the
    combined value with its 1-sigma band, and the truth when known. Right: each pool's
    centre displacement across the line of sight from the latency-free centre (um)
    against rate; the latency rotates +omega and -omega pools apart by ``omega tau D``.
    """
    rates = np.array([r.rate_deg_s for r in result.per_rate])
    tau = np.array([r.latency_s for r in result.per_rate]) * 1e3
    std = np.array([r.latency_std_s for r in result.per_rate]) * 1e3
    first = np.array([r.latency_first_order_s for r in result.per_rate]) * 1e3
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.3))
    lo = result.latency_s * 1e3 - result.latency_std_s * 1e3
    hi = result.latency_s * 1e3 + result.latency_std_s * 1e3
    ax.axhspan(lo, hi, color="C0", alpha=0.15, label="combined ±1σ")
    ax.axhline(result.latency_s * 1e3, color="C0", lw=1)
    ax.errorbar(rates, tau, yerr=std, fmt="o", color="C0", capsize=3, label="per rate (exact)")
    ax.plot(rates, first, "x", color="C1", label="first-order formula")
    if truth_latency_s is not None:
        ax.axhline(truth_latency_s * 1e3, color="k", ls="--", lw=1, label="truth")
    ax.set_xlabel("table rate (deg/s)")
    ax.set_ylabel("latency (ms)")
    ax.set_title(f"Latency {result.latency_s * 1e3:.4f} ± {result.latency_std_s * 1e3:.4f} ms")
    ax.grid(visible=True, alpha=0.3)
    ax.legend(fontsize=8)
    centre = result.sphere_center_ned_m
    horizontal = np.array([centre[0], centre[1], 0.0])
    across = np.cross([0.0, 0.0, 1.0], horizontal / np.linalg.norm(horizontal))
    for r in result.per_rate:
        for pool, marker in ((r.plus, "^"), (r.minus, "v")):
            shift = (pool.fit.center_m - r.center_ned_m) @ across * 1e6
            sig = math.sqrt(float(across @ pool.fit.cov_center_m2 @ across)) * 1e6
            ax2.errorbar(r.rate_deg_s, shift, yerr=sig, fmt=marker, color="C2", capsize=2)
    d = float(np.linalg.norm(horizontal))
    grid = np.linspace(0.0, rates.max() * 1.05, 50)
    model = np.radians(grid) * result.latency_s * d * 1e6
    ax2.plot(grid, model, "k:", lw=1, label="±ω τ D")
    ax2.plot(grid, -model, "k:", lw=1)
    ax2.set_xlabel("table rate (deg/s)")
    ax2.set_ylabel("centre shift across the line of sight (µm)")
    ax2.set_title("Pool centres: ▲ clockwise, ▼ counter-clockwise")
    ax2.grid(visible=True, alpha=0.3)
    ax2.legend(fontsize=8)
    return png_bytes(fig)


@report_figure
def plan_figure(plan: LatencyPlan, target_latency_std_s: float = 1e-4) -> bytes:
    """Predicted latency sigma per rate and combined, against passes per direction."""
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    rates = [r.rate_deg_s for r in plan.per_rate]
    ax.semilogy(rates, [r.latency_std_s * 1e3 for r in plan.per_rate], "o-", label="per rate")
    ax.axhline(plan.latency_std_s * 1e3, color="C0", ls="--", label="all rates")
    ax.axhline(target_latency_std_s * 1e3, color="k", ls=":", label="target")
    ax.set_xlabel("table rate (deg/s)")
    ax.set_ylabel("predicted latency σ (ms)")
    ax.set_title(f"Cramér-Rao bound, {counted(plan.design.passes, 'pass')} each way")
    ax.grid(visible=True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    passes = np.arange(1, max(4 * plan.design.passes, 20) + 1)
    combined = plan.latency_std_s * np.sqrt(plan.design.passes / passes) * 1e3
    ax2.loglog(passes, combined, "-")
    ax2.axhline(target_latency_std_s * 1e3, color="k", ls=":", label="target")
    ax2.set_xlabel("passes per rate and direction")
    ax2.set_ylabel("predicted latency σ, all rates (ms)")
    ax2.grid(visible=True, which="both", alpha=0.3)
    ax2.legend(fontsize=8)
    return png_bytes(fig)
