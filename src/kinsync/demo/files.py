"""The files a demo section leaves beside the report: its figures and its document."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from kinsync.io.atomic import atomic_write_bytes, atomic_write_text
from kinsync.report.html import Figure

__all__ = ["write_section_files"]


def write_section_files(
    out_dir: Path, stem: str, figures: Sequence[Figure], doc: Mapping[str, Any] | None = None
) -> None:
    """Write ``{stem}_1.png``, ``{stem}_2.png``, ... and ``{stem}.json``, each atomically.

    Parameters
    ----------
    out_dir : Path
        The demo's output folder.
    stem : str
        The section's file name stem (``ins``, ``calibration``, ...).
    figures : sequence of Figure
        Written in order, numbered from 1.
    doc : mapping, optional
        The section's JSON document (indented by 2, NaN written as ``NaN``); none when
        omitted.
    """
    for i, fig in enumerate(figures, start=1):
        atomic_write_bytes(out_dir / f"{stem}_{i}.png", fig.png)
    if doc is not None:
        atomic_write_text(out_dir / f"{stem}.json", json.dumps(doc, indent=2) + "\n")
