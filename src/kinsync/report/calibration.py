"""The calibration certificate: a one-page HTML report of a mount calibration.

Verdict first (what changed, by how much, with its standard deviation and status),
then what could not be determined and why, each feature's residuals and line-to-line
scatter before and after, the correlations, and a figure of the overlap differences
(where each line alone puts each feature, before and after).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes

from kinsync.calibration.overlaps import LineOverlap
from kinsync.calibration.parameters import PARAMETER_NAMES
from kinsync.calibration.result import CalibrationResult, ParameterEstimate
from kinsync.io.provenance import run_record
from kinsync.report.figures import png_bytes
from kinsync.report.html import Figure, Section, Table, render_report
from kinsync.report.style import report_figure

__all__ = [
    "calibration_certificate",
    "calibration_sections",
    "overlap_figure",
    "parameter_rows",
    "verdict",
]

_FEATURE_HEADERS = (
    "feature",
    "lines",
    "returns",
    "RMS before",
    "RMS after",
    "scatter before",
    "scatter after",
)


def _unit(name: str) -> str:
    return name.rsplit("_", 1)[-1]


def _value(p: ParameterEstimate) -> str:
    digits = {"deg": 4, "m": 4, "ms": 3}[_unit(p.name)]
    return f"{p.value:.{digits}f}"


def _std(p: ParameterEstimate) -> str:
    return "-" if not math.isfinite(p.std) else f"{p.std:.2g}"


def _held_part(p: ParameterEstimate) -> str:
    return "-" if not math.isfinite(p.held_std) else f"{p.held_std:.2g}"


def parameter_rows(result: CalibrationResult) -> list[list[str]]:
    """Rows: parameter, prior, calibrated, change, sigma, of which held, formal sigma, status."""
    rows = []
    for p in result.parameters:
        unit = _unit(p.name)
        digits = {"deg": 4, "m": 4, "ms": 3}[unit]
        rows.append(
            [
                p.name.removesuffix(f"_{unit}").replace("_", " ") + f" ({unit})",
                f"{p.prior:.{digits}f}",
                _value(p),
                f"{p.change:+.{digits}f}",
                _std(p),
                _held_part(p),
                "-" if not math.isfinite(p.formal_std) else f"{p.formal_std:.2g}",
                p.status,
            ]
        )
    return rows


def verdict(result: CalibrationResult) -> str:
    """One paragraph: what changed, by how much, with sigma; what could not be found."""
    changed = [
        f"{p.name} {p.prior:.4g} -> {_value(p)} (+-{_std(p)}, {p.status})"
        for p in result.parameters
        if p.status in ("estimated", "weak")
    ]
    held = [p.name for p in result.parameters if p.status == "unobservable"]
    text = "Calibrated: " + ("; ".join(changed) if changed else "nothing") + "."
    if held:
        text += f" Not determined by these data, held at their prior values: {', '.join(held)}."
    before, after = result.residual_rms_before_m, result.residual_rms_after_m
    text += (
        f" Residual RMS over {len(result.features)} features and {len(result.lines)} lines: "
        f"{before * 100:.2f} cm before, {after * 100:.2f} cm after."
    )
    return text


_BEFORE, _AFTER = "#9a9a9a", "#1f5f9f"


def _series(
    before: Sequence[LineOverlap], after: Sequence[LineOverlap]
) -> tuple[tuple[Sequence[LineOverlap], str, str], ...]:
    return ((before, _BEFORE, "starting mount"), (after, _AFTER, "calibrated"))


def _sphere_panels(
    axes: Sequence[Axes], before: Sequence[LineOverlap], after: Sequence[LineOverlap],
    spheres: Sequence[int], titles: Sequence[str],
) -> None:  # fmt: skip
    """Plan view of each sphere's per-line centres about their mean (cm)."""
    for ax, k in zip(axes, spheres, strict=True):
        for data, colour, label in _series(before, after):
            off = np.array([o.offset_ned_m for o in data if o.feature == k])
            off = off[np.all(np.isfinite(off), axis=1)] if off.size else np.zeros((0, 3))
            if not off.size:
                continue
            off = (off - off.mean(axis=0)) * 100.0
            rms = float(np.sqrt(np.mean(off[:, 0] ** 2 + off[:, 1] ** 2)))
            ax.scatter(off[:, 1], off[:, 0], s=28, color=colour,
                       label=f"{label}: {rms:.1f} cm RMS")  # fmt: skip
        ax.axhline(0.0, color="k", lw=0.5)
        ax.axvline(0.0, color="k", lw=0.5)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{k}: {titles[k]}", fontsize=9)
        ax.set_xlabel("east (cm)")
        ax.set_ylabel("north (cm)")
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)


_MAX_PLANE_LABELS = 24
"""Plane numbers labelled on a panel's x axis at most: beyond, every second (third...)."""


def _plane_ticks(ax: Axes, planes: Sequence[int]) -> None:
    """Label the planes upright-rotated, thinned to `_MAX_PLANE_LABELS`; a tick each.

    Upright, 28 plane numbers ran together once the report enlarged them to be read.
    """
    step = max(1, math.ceil(len(planes) / _MAX_PLANE_LABELS))
    shown = list(range(0, len(planes), step))
    ax.set_xticks(shown)
    ax.set_xticklabels([str(planes[x]) for x in shown], rotation=90)
    if step > 1:
        ax.set_xticks(range(len(planes)), minor=True)


def _plane_panels(
    axes: Sequence[Axes], before: Sequence[LineOverlap], after: Sequence[LineOverlap],
    planes: Sequence[int],
) -> None:  # fmt: skip
    """Each plane's per-line offsets along its normal about their mean (cm)."""
    for ax, (data, colour, label) in zip(axes, _series(before, after), strict=True):
        all_dev = []
        for x, k in enumerate(planes):
            d = np.array([o.normal_m for o in data if o.feature == k])
            d = d[np.isfinite(d)]
            if d.size < 2:
                continue
            dev = (d - d.mean()) * 100.0
            all_dev.append(dev)
            ax.scatter(np.full(dev.size, x), dev, s=12, color=colour)
        rms = float(np.sqrt(np.mean(np.concatenate(all_dev) ** 2))) if all_dev else math.nan
        ax.set_title(f"{label}: {rms:.2f} cm RMS", fontsize=10)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel("plane (number as in the table)")
        _plane_ticks(ax, planes)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("one line's offset along the normal (cm)")


@report_figure
def overlap_figure(
    before: Sequence[LineOverlap],
    after: Sequence[LineOverlap],
    titles: Sequence[str],
    kinds: Sequence[str],
) -> bytes:
    """Where each line alone puts each feature, about the lines' mean, before and after.

    Spheres: plan view of the per-line centres (cm), one panel per sphere (up to 4).
    Planes: each line's offset along the plane's normal (cm), before and after side by
    side, each on its own scale (the calibrated one is usually much tighter).
    """
    spheres = [k for k, kind in enumerate(kinds) if kind == "sphere"][:4]
    planes = [k for k, kind in enumerate(kinds) if kind == "plane"]
    n_panels = len(spheres) + (2 if planes else 0)
    fig, axes = plt.subplots(1, max(n_panels, 1), figsize=(4.2 * max(n_panels, 1) + 1, 4.2))
    panels: list[Axes] = list(np.atleast_1d(axes))
    _sphere_panels(panels[: len(spheres)], before, after, spheres, titles)
    if planes:
        _plane_panels(panels[len(spheres) :], before, after, planes)
    fig.tight_layout()
    return png_bytes(fig)


def _held_paragraphs(result: CalibrationResult) -> tuple[str, ...]:
    """What each held parameter's error does to the estimates, and which are taken as exact."""
    if result.held is None:
        solved = any(p.status in ("estimated", "weak") for p in result.parameters)
        return ("Nothing held: every parameter was estimated.",) if solved else ("Nothing solved.",)
    held = result.held
    known = [PARAMETER_NAMES[i] for i in held.held if i not in held.unknown]
    exact = [PARAMETER_NAMES[i] for i in held.unknown]
    intro = "Held at their prior values."
    if known:
        intro += (
            f" The sigma holds the stated uncertainty (the mount's [uncertainty]) of "
            f"{', '.join(known)}: column 'of which held', combined with the data's in "
            "quadrature."
        )
    if exact:
        intro += f" Taken as exact (no [uncertainty] given): {', '.join(exact)}."
    intro += (
        " What an error of each does, linearised at the solution with its weights and noise "
        "scales held:"
    )
    return (intro, *held.lines(), *(f"Warning: {a}." for a in result.held_advice))


def calibration_sections(result: CalibrationResult) -> list[Section]:
    """The certificate's sections (also used by the demo's report)."""
    headers = (
        "parameter",
        "prior",
        "calibrated",
        "change",
        "sigma",
        "of which held",
        "formal sigma",
        "status",
    )
    features = [
        [
            f"{i}: {f.description}",
            str(f.n_passes),
            str(f.n_points),
            f"{f.rms_before_m * 100:.2f}",
            f"{f.rms_after_m * 100:.2f}",
            f"{f.scatter_before_m[0] * 100:.1f} / {f.scatter_before_m[1] * 100:.1f}",
            f"{f.scatter_after_m[0] * 100:.1f} / {f.scatter_after_m[1] * 100:.1f}",
        ]
        for i, f in enumerate(result.features)
    ]
    corr = [
        [name, *(f"{v:+.2f}" for v in row)]
        for name, row in zip(result.correlation_names, result.correlation, strict=True)
    ]
    why = list(result.unobservable_reasons) + [f"Would determine them: {a}." for a in result.advice]
    return [
        Section(
            title="Verdict",
            paragraphs=(
                *(f"Warning: {w}." for w in result.warnings),
                verdict(result),
                f"Standard deviations: {result.sigma_method}.",
            ),
            tables=(Table("Mount parameters", headers, parameter_rows(result)),),
        ),
        Section(title="What the data could not determine", paragraphs=tuple(why) or ("Nothing.",)),
        Section(title="Held parameters", paragraphs=_held_paragraphs(result)),
        Section(
            title="Features",
            tables=(
                Table(
                    "Residual RMS (cm) and scatter of where each line puts the feature "
                    "(horizontal / vertical, cm), starting mount and calibrated",
                    _FEATURE_HEADERS,
                    features,
                ),
                Table("Correlations of the estimates", ("", *result.correlation_names), corr),
            ),
            figures=(
                Figure(
                    "Overlap differences: where each line alone puts each feature, relative to "
                    "all lines, with the starting mount and calibrated",
                    overlap_figure(
                        result.overlaps_before,
                        result.overlaps_after,
                        [f.description for f in result.features],
                        [f.kind for f in result.features],
                    ),
                ),
            ),
        ),
        Section(
            title="Lines",
            paragraphs=(
                ", ".join(result.lines),
                *(f"Rejected {name}: {reason}." for name, reason in result.rejected_lines),
            ),
        ),
    ]


def calibration_certificate(result: CalibrationResult) -> str:
    """The complete one-page HTML certificate.

    It ends with what produced it (`kinsync.io.provenance.run_record`): the software and
    its commit, the date (UTC), the command line (every input file and option) and the
    folder it ran in, so that the calibration can be run again.
    """
    intro = (
        "Mount self-calibration from survey data (kinsync): boresight, lever arm and "
        "latency estimated with the features the lines share as nuisance parameters. "
        "Latency sign: > 0 means the navigation records lag the scanner."
    )
    record = run_record()
    about = [
        ("software", str(record["software"])),
        ("date (UTC)", str(record["utc"])),
        ("command", record["command"] or "(run from Python: no command line)"),
        ("working folder", str(Path.cwd())),
    ]
    return render_report(
        "kinsync mount calibration", intro, calibration_sections(result), about=about
    )
