"""Report figures: readable at 100 % zoom, colour-blind safe series, legends off the data."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_hex
from matplotlib.figure import Figure

from kinsync.report import figures
from kinsync.report.figures import png_bytes
from kinsync.report.style import (
    MIN_TEXT_PX,
    OKABE_ITO,
    legends_over_data,
    make_readable,
    report_figure,
    small_texts,
)


def _crowded(width_in: float = 15.0) -> Figure:
    """A wide figure with small text and a legend sitting on the data."""
    fig, ax = plt.subplots(figsize=(width_in, 4))
    x = np.linspace(0.0, 1.0, 200)
    ax.plot(x, np.ones_like(x), label="flat")
    ax.plot(x, x, label="rising")
    ax.set_ylim(0.0, 1.05)
    ax.set_title("tiny", fontsize=6)
    ax.tick_params(labelsize=6)
    ax.legend(loc="upper right", fontsize=6)
    return fig


def test_small_text_is_found_and_enlarged() -> None:
    fig = _crowded()
    small = small_texts(fig)
    assert small
    assert min(px for _, px in small) < MIN_TEXT_PX
    make_readable(fig)
    assert small_texts(fig) == []
    plt.close(fig)


def test_a_narrow_figure_needs_smaller_fonts_than_a_wide_one() -> None:
    wide, narrow = _crowded(15.0), _crowded(5.0)
    px = {
        name: dict(small_texts(f)).get("tiny", np.inf) for name, f in (("w", wide), ("n", narrow))
    }
    assert px["w"] < px["n"]
    plt.close(wide)
    plt.close(narrow)


def test_a_legend_on_the_data_is_moved_off_it() -> None:
    fig = _crowded()
    assert legends_over_data(fig)
    make_readable(fig)
    assert legends_over_data(fig) == []
    plt.close(fig)


def test_png_bytes_leaves_the_figure_readable() -> None:
    fig = _crowded()
    assert png_bytes(fig).startswith(b"\x89PNG")
    assert small_texts(fig) == []
    assert legends_over_data(fig) == []


def test_series_differ_in_colour_and_line_style() -> None:
    @report_figure
    def draw() -> list[tuple[str, object]]:
        fig, ax = plt.subplots()
        lines = [ax.plot([0, 1], [i, i])[0] for i in range(4)]
        plt.close(fig)
        return [(to_hex(line.get_color()), line.get_linestyle()) for line in lines]

    styles = draw()
    assert [c for c, _ in styles] == [c.lower() for c in OKABE_ITO[:4]]
    assert len({ls for _, ls in styles}) == 4
    # outside a report figure the user's own defaults are untouched
    fig, ax = plt.subplots()
    (line,) = ax.plot([0, 1], [0, 1])
    plt.close(fig)
    assert to_hex(line.get_color()) != OKABE_ITO[0].lower()


def test_report_figures_come_out_readable(monkeypatch: pytest.MonkeyPatch) -> None:
    """The budget figures (wide, three panels, legends) pass the checks once made."""
    made: list[Figure] = []
    original = figures.png_bytes

    def keep(fig: Figure) -> bytes:
        made.append(fig)
        return original(fig)

    monkeypatch.setattr(figures, "png_bytes", keep)
    figures.beach_budget_figure(50.0, 10.0, (5.0, 10.0, 20.0), (0.1, 1.0, 10.0, 100.0))
    figures.rolling_table_figure((0.1, 1.0, 10.0))
    assert len(made) == 2
    for fig in made:
        assert small_texts(fig) == []
        assert legends_over_data(fig) == []


def test_a_legend_with_a_neighbour_on_its_right_goes_below() -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4))
    x = np.linspace(0.0, 1.0, 400)
    for k in range(6):
        left.plot(x, x + 0.15 * k, label=f"series {k}")
        right.plot(x, x)
    left.legend(loc="center")
    assert legends_over_data(fig)
    make_readable(fig)
    assert legends_over_data(fig) == []
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    box = left.get_legend().get_window_extent(renderer)
    assert box.y1 < left.get_window_extent(renderer).y0  # under the axes
    assert not box.overlaps(right.get_window_extent(renderer))
    plt.close(fig)
