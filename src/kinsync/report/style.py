"""How report figures look: readable at 100 % zoom, colour-blind safe, nothing hidden.

Every report figure is drawn under `REPORT_RC` (the `report_figure` decorator or the
`report_style` context) and finished by `make_readable` before it is saved:

- **Colours** come from the Okabe-Ito palette, which stays distinguishable under the
  common colour-vision deficiencies (Okabe & Ito, *Color Universal Design*, 2008; Wong,
  *Points of view: Color blindness*, Nature Methods 8, 441, 2011), and each colour in
  the cycle has its own line style, so series differ in more than colour.
- **Text** is at least `MIN_TEXT_PX` pixels high as the page shows it: the report's
  column is `REPORT_WIDTH_PX` wide and scales a wider figure down, so a wide figure needs
  larger fonts; `make_readable` enlarges what is smaller.
- **Legends** do not cover data: a legend with data points under it is moved to where
  it covers none ("best"), or else outside the axes.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, Literal, ParamSpec, TypeVar

import matplotlib as mpl

mpl.use("Agg")
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.backend_bases import RendererBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PathCollection
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.rcsetup import cycler
from matplotlib.text import Text

from kinsync._typing import FloatArray

__all__ = [
    "MIN_TEXT_PX",
    "OKABE_ITO",
    "REPORT_DPI",
    "REPORT_RC",
    "REPORT_WIDTH_PX",
    "legends_over_data",
    "make_readable",
    "report_figure",
    "report_style",
    "small_texts",
]

P = ParamSpec("P")
R = TypeVar("R")

OKABE_ITO = (
    "#0072B2",  # blue
    "#E69F00",  # orange
    "#009E73",  # bluish green
    "#D55E00",  # vermillion
    "#CC79A7",  # reddish purple
    "#56B4E9",  # sky blue
    "#000000",  # black
    "#F0E442",  # yellow (last: weak on white)
)
"""The Okabe-Ito palette; ``C0``-``C7`` in a report figure name these colours in order."""

_LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)), "-", "--")

REPORT_RC: dict[str, Any] = {
    "axes.prop_cycle": cycler(color=OKABE_ITO) + cycler(linestyle=_LINESTYLES),
    "font.size": 10.0,
    "axes.titlesize": 11.0,
    "axes.labelsize": 10.0,
    "xtick.labelsize": 10.0,
    "ytick.labelsize": 10.0,
    "legend.fontsize": 10.0,
    "legend.framealpha": 0.9,
    "figure.titlesize": 12.0,
    "image.cmap": "viridis",
}
"""The rcParams every report figure is drawn under."""

REPORT_DPI = 110
"""Resolution the report's PNG figures are saved at."""

REPORT_WIDTH_PX = 1060
"""Width (CSS pixels) of the report's column: a wider PNG is shown scaled down to it."""

MIN_TEXT_PX = 11.0
"""Smallest text height (CSS pixels at 100 % zoom) a figure may show."""


@contextmanager
def report_style() -> Iterator[None]:
    """Draw the figures made inside under `REPORT_RC`."""
    rc: Any = REPORT_RC
    with mpl.rc_context(rc):
        yield


def report_figure(func: Callable[P, R]) -> Callable[P, R]:
    """Decorate a function that draws a report figure: it runs under `REPORT_RC`."""

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with report_style():
            return func(*args, **kwargs)

    return wrapper


def _renderer(fig: Figure) -> RendererBase:
    """The figure's renderer: text extents and legend places need it, not a full draw."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    return canvas.get_renderer()  # type: ignore[no-untyped-call, no-any-return]


def _px_per_point(fig: Figure, renderer: RendererBase, dpi: float) -> float:
    """CSS pixels per font point once the saved PNG is shown in the report's column.

    The width is the larger of the figure's and its tight box's (a layout pass may yet
    widen the axes to the figure's edges), so the estimate errs towards smaller text.
    """
    tight_in = float(fig.get_tightbbox(renderer).width) + 0.2  # savefig's pad_inches
    width_in = max(tight_in, float(fig.get_figwidth()))
    shown = min(1.0, REPORT_WIDTH_PX / (width_in * dpi))
    return dpi / 72.0 * shown


def _texts(fig: Figure) -> list[Text]:
    return [
        t
        for t in fig.findobj(Text)
        if isinstance(t, Text) and t.get_visible() and t.get_text().strip()
    ]


def small_texts(fig: Figure, dpi: float = REPORT_DPI) -> list[tuple[str, float]]:
    """Texts shown below `MIN_TEXT_PX` in the report: (text, CSS pixels), smallest first."""
    renderer = _renderer(fig)
    scale = _px_per_point(fig, renderer, dpi)
    small = [(t.get_text(), float(t.get_fontsize()) * scale) for t in _texts(fig)]
    return sorted(((s, px) for s, px in small if px < MIN_TEXT_PX - 1e-6), key=lambda x: x[1])


def _data_points_px(ax: Axes) -> FloatArray:
    """Display coordinates of the axes' line vertices and scatter points."""
    chunks = [
        line.get_transform().transform(np.asarray(line.get_xydata(), dtype=np.float64))
        for line in ax.get_lines()
        if line.get_visible()
    ]
    for coll in ax.collections:
        if isinstance(coll, PathCollection) and coll.get_visible():
            offsets = np.asarray(coll.get_offsets(), dtype=np.float64)
            if offsets.size:
                chunks.append(coll.get_offset_transform().transform(offsets))
    if not chunks:
        return np.empty((0, 2))
    pts = np.concatenate([np.asarray(c, dtype=np.float64).reshape(-1, 2) for c in chunks])
    return np.asarray(pts[np.isfinite(pts).all(axis=1)], dtype=np.float64)


def _covered(ax: Axes, legend: Legend, renderer: RendererBase) -> int:
    box = legend.get_window_extent(renderer)
    pts = _data_points_px(ax)
    inside = (
        (pts[:, 0] >= box.x0)
        & (pts[:, 0] <= box.x1)
        & (pts[:, 1] >= box.y0)
        & (pts[:, 1] <= box.y1)
    )
    return int(inside.sum())


def legends_over_data(fig: Figure) -> list[tuple[str, int]]:
    """Axes whose legend covers data: (axes title or index, data points under it)."""
    renderer = _renderer(fig)
    found = []
    for i, ax in enumerate(fig.axes):
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            n = _covered(ax, legend, renderer)
            if n:
                found.append((ax.get_title() or f"axes {i}", n))
    return found


def _enlarge_small_text(fig: Figure, px_per_point: float) -> bool:
    """Bring every text up to `MIN_TEXT_PX`; True when something changed."""
    # a little above the minimum: larger text widens the figure, which shrinks it on the page
    need_pt = 1.06 * MIN_TEXT_PX / px_per_point
    changed = False
    for ax in fig.axes:
        pairs: tuple[tuple[Axis, Literal["x", "y"]], ...] = ((ax.xaxis, "x"), (ax.yaxis, "y"))
        for axis, which in pairs:
            labels = [t for t in axis.get_ticklabels(which="both") if t.get_text().strip()]
            if labels and min(float(t.get_fontsize()) for t in labels) < need_pt:
                ax.tick_params(axis=which, which="both", labelsize=need_pt)
                changed = True
    for t in _texts(fig):
        if float(t.get_fontsize()) < need_pt:
            t.set_fontsize(need_pt)
            changed = True
    return changed


def _relayout(fig: Figure) -> None:
    if fig.get_layout_engine() is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fig.tight_layout()


def _place_outside(fig: Figure, ax: Axes, legend: Legend, renderer: RendererBase) -> bool:
    """Put ``legend`` right of ``ax`` or under its x axis, where no other axes are.

    Returns False (the legend stays at "best") when axes sit on both sides.
    """
    pos = ax.get_position()
    others = [o.get_position() for o in fig.axes if o is not ax and o.get_visible()]
    if not any(o.x0 >= pos.x1 - 1e-3 and o.y0 < pos.y1 and o.y1 > pos.y0 for o in others):
        legend.set_loc("upper left")
        legend.set_bbox_to_anchor((1.02, 1.0), transform=ax.transAxes)
        return True
    if not any(o.y1 <= pos.y0 + 1e-3 and o.x0 < pos.x1 and o.x1 > pos.x0 for o in others):
        box = ax.get_window_extent(renderer)
        axis_box = ax.xaxis.get_tightbbox(renderer)
        bottom = axis_box.y0 if axis_box is not None else box.y0
        y = (bottom - box.y0) / max(box.height, 1.0) - 0.02
        legend.set_loc("upper center")
        legend.set_bbox_to_anchor((0.5, y), transform=ax.transAxes)
        return True
    return False


def make_readable(fig: Figure, dpi: float = REPORT_DPI) -> None:
    """Enlarge text below `MIN_TEXT_PX` and move legends off the data, in place.

    A legend with data under it goes where matplotlib finds the fewest points ("best");
    if data remain under it, it goes outside the axes, to the right or else below, where
    no other axes are (and the text is checked again, the figure being larger).
    """
    renderer = _renderer(fig)
    if _enlarge_small_text(fig, _px_per_point(fig, renderer, dpi)):
        _relayout(fig)
    moved_out = False
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None or not legend.get_visible() or not _covered(ax, legend, renderer):
            continue
        legend.set_loc("best")
        if _covered(ax, legend, renderer):
            moved_out = _place_outside(fig, ax, legend, renderer) or moved_out
    if moved_out and _enlarge_small_text(fig, _px_per_point(fig, renderer, dpi)):
        _relayout(fig)
