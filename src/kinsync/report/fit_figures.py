"""Figures of sphere fits (matplotlib, Agg backend, PNG bytes)."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from kinsync._typing import FloatArray
from kinsync.errors import InputError
from kinsync.fit import SphereFit
from kinsync.report.figures import png_bytes
from kinsync.report.style import report_figure

__all__ = ["angle_from_cap_axis_deg", "sphere_residual_figure"]


def angle_from_cap_axis_deg(fit: SphereFit, points_m: FloatArray) -> FloatArray:
    """Angle (deg) of each point from the axis of the fitted cap, seen from the centre.

    The cap axis is the mean direction from the centre to the inliers; on a one-sided
    cap, 0 deg is the point facing the scanner and large angles are near the silhouette,
    where a wrong radius or a range bias shows first.

    Parameters
    ----------
    fit : SphereFit
        Fit of ``points_m``.
    points_m : ndarray, shape (N, 3)
        The points given to the fit (m), same frame.

    Returns
    -------
    ndarray, shape (N,)
        Angles in degrees, 0-180.
    """
    pts = np.asarray(points_m, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] != fit.residuals_m.shape[0]:
        msg = (
            f"angle_from_cap_axis_deg: points_m must have shape ({fit.residuals_m.shape[0]}, 3) "
            f"to match the fit, got {pts.shape}"
        )
        raise InputError(msg)
    rel = pts - fit.center_m
    unit = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    axis = unit[fit.inliers].mean(axis=0)
    norm = float(np.linalg.norm(axis))
    axis = axis / norm if norm > 0.0 else np.array([0.0, 0.0, 1.0])
    angles: FloatArray = np.degrees(np.arccos(np.clip(unit @ axis, -1.0, 1.0)))
    return angles


@report_figure
def sphere_residual_figure(
    fits: Sequence[tuple[str, SphereFit]], points: Sequence[FloatArray]
) -> bytes:
    """Residuals of sphere fits: against the angle from the cap axis, and histograms.

    Left: residual (mm) of every inlier against its angle from the cap axis (a
    systematic trend means a wrong radius, a range bias or a distorted pass). Right:
    histogram of the inlier residuals, one outline per fit, with the RMS in the legend.
    Typical use: one pass fitted with free and with fixed radius.

    Parameters
    ----------
    fits : sequence of (str, SphereFit)
        Label and fit, e.g. ``("sphere1 pass 1, free radius", fit)``.
    points : sequence of ndarray, shape (N_k, 3)
        The points given to each fit (m), in the same order.

    Returns
    -------
    bytes
        PNG image.

    Raises
    ------
    InputError
        No fits, or ``points`` not matching ``fits``.
    """
    if not fits:
        msg = "sphere_residual_figure: no fits to draw"
        raise InputError(msg)
    if len(points) != len(fits):
        msg = (
            f"sphere_residual_figure: {len(fits)} fits but {len(points)} point arrays; "
            "give the points of each fit, in the same order"
        )
        raise InputError(msg)
    fig, (ax_angle, ax_hist) = plt.subplots(1, 2, figsize=(13, 4.6))
    all_res = np.concatenate(
        [fit.residuals_m[fit.inliers & np.isfinite(fit.residuals_m)] for _, fit in fits]
    )
    lim_mm = float(np.percentile(np.abs(all_res), 99.5) * 1e3) if all_res.size else 1.0
    lim_mm = max(lim_mm, 1e-3)
    bins = np.linspace(-lim_mm, lim_mm, 41)
    cmap = plt.get_cmap("tab10" if len(fits) <= 10 else "tab20")
    for k, ((label, fit), pts) in enumerate(zip(fits, points, strict=True)):
        color = cmap(k % cmap.N)
        angles = angle_from_cap_axis_deg(fit, pts)
        keep = fit.inliers & np.isfinite(fit.residuals_m)
        res_mm = fit.residuals_m[keep] * 1e3
        kind = "fixed" if fit.radius_fixed else "free"
        ax_angle.plot(angles[keep], res_mm, ".", ms=2.5, alpha=0.6, color=color)
        ax_hist.hist(
            np.clip(res_mm, -lim_mm, lim_mm),
            bins=bins,
            histtype="step",
            color=color,
            label=(
                f"{label}: R {fit.radius_m:.4f} m ({kind}), RMS "
                f"{fit.residual_rms_m * 1e3:.2f} mm, n {fit.n_points}"
            ),
        )
    ax_angle.axhline(0.0, color="k", lw=0.8)
    ax_angle.set_ylim(-lim_mm, lim_mm)
    ax_angle.set_xlabel("angle from the cap axis, seen from the centre (deg)")
    ax_angle.set_ylabel("residual (mm)")
    ax_angle.set_title("Residual across the visible cap")
    ax_angle.grid(visible=True, alpha=0.3)
    ax_hist.set_xlabel("residual (mm)")
    ax_hist.set_ylabel("points")
    ax_hist.set_title("Residual distribution (inliers)")
    ax_hist.grid(visible=True, alpha=0.3)
    # Below both panels, in two columns: right of the histogram the long labels took
    # half the figure's width and squeezed the panels.
    fig.tight_layout()
    handles, labels = ax_hist.get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="upper center",
        bbox_to_anchor=(0.5, 0.0),
        ncol=min(2, len(fits)),
        fontsize=7,
    )
    return png_bytes(fig)
