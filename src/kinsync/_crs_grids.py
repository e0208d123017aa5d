"""The grids a PROJ transformation needs, and the message when PROJ cannot have them.

Split from `kinsync.crs`: a compound CRS (orthometric heights) needs a geoid grid; PROJ
may lack it, or (``PROJ_NETWORK=ON`` on a host without network) fail to download it.
Either is refused naming each grid, what it does and how to install it.
"""

from __future__ import annotations

import re
from typing import Any

import pyproj
from pyproj.datadir import get_user_data_dir  # type: ignore[attr-defined]
from pyproj.transformer import Transformer, TransformerGroup

from kinsync.errors import InputError

__all__ = ["check_grids_reachable", "grid_roles", "missing_grid_message", "pipeline_text"]

_GRID_ROLES = {
    "vgridshift": "geoid model",
    "hgridshift": "horizontal datum shift",
    "gridshift": "datum shift",
    "deformation": "deformation model",
    "xyzgridshift": "datum shift",
}
"""What a grid does, by the PROJ step that reads it."""


def grid_roles(operation: Any) -> dict[str, str]:
    """Each grid of a PROJ operation and what it does (from its ``+grids=`` steps).

    Parameters
    ----------
    operation : Any
        A pyproj coordinate operation or transformer (anything with ``to_proj4``).
    """
    try:
        text = str(operation.to_proj4())
    except pyproj.exceptions.CRSError:
        return {}
    roles: dict[str, str] = {}
    for step in text.split("+step"):
        method = re.search(r"\+proj=(\w+)", step)
        grids = re.search(r"\+grids=(\S+)", step)
        if method and grids:
            for name in grids.group(1).split(","):
                roles.setdefault(name.lstrip("@"), _GRID_ROLES.get(method.group(1), "grid"))
    return roles


def missing_grid_message(
    target_text: str, group: TransformerGroup, chosen: Transformer | None = None
) -> str:
    """Name the grids the best transformation lacks, each with what it does.

    Parameters
    ----------
    target_text : str
        The CRS as the user gave it (``--crs``).
    group : TransformerGroup
        PROJ's transformations to it; the best unavailable one names the grids.
    chosen : Transformer, optional
        A transformation whose grids PROJ could not download (``PROJ_NETWORK=ON`` on a
        host without network): its grids not on this host are named instead.
    """
    best: Any = chosen
    if chosen is not None:
        grids = {g.short_name: g for op in chosen.operations or () for g in op.grids}
        missing = [g for g in grids.values() if not g.full_name]  # not on this host
    else:
        best = group.unavailable_operations[0] if group.unavailable_operations else None
        missing = [g for g in best.grids if not g.available] if best is not None else []
    if not missing:
        return (
            f"--crs {target_text!r}: PROJ knows no geoid model from the ellipsoid to these "
            "heights for this area; give one with --geoid PATH (a grid of geoid heights N "
            "above the ellipsoid, GTX or GeoTIFF)"
        )
    roles = grid_roles(best)
    # The geoid first: it is what the orthometric heights need.
    missing.sort(key=lambda g: roles.get(g.short_name) != "geoid model")
    first, others = missing[0], missing[1:]
    role = roles.get(first.short_name)
    also = "".join(f", and also {g.short_name} ({roles.get(g.short_name, 'grid')})" for g in others)
    installs = " and ".join(f"`projsync --file {g.short_name}`" for g in missing)
    urls = ", ".join(g.url or g.short_name for g in missing)
    it = "it" if not others else "them"
    network = "or set PROJ_NETWORK=ON, "
    if chosen is not None:  # PROJ_NETWORK=ON is set
        network = f"as PROJ_NETWORK=ON could not download {it} (no network?), "
    return (
        f"--crs {target_text!r}: orthometric heights need the grid {first.short_name}"
        f"{f' ({role})' if role else ''}, which PROJ does not have{also}; install "
        f"{it} with {installs} (or download {urls} into {get_user_data_dir()}), "
        f"{network}or give a geoid grid with --geoid PATH. Without {it} PROJ would leave "
        "ellipsoidal heights under the orthometric label"
    )


def check_grids_reachable(target_text: str, transformer: Transformer, group: Any) -> None:
    """Refuse a transformation whose grids PROJ_NETWORK=ON cannot download, as missing ones.

    With the network enabled PROJ counts every grid of its CDN as available and chooses
    a transformation that needs one; without a network, building it failed deep inside
    PROJ (``ProjError: Invalid projection``, an internal error).

    Parameters
    ----------
    target_text : str
        The CRS as the user gave it (``--crs``).
    transformer : Transformer
        The transformation chosen.
    group : Any
        The `TransformerGroup` it was chosen from.

    Raises
    ------
    InputError
        A grid it needs is not on this host and PROJ cannot build the transformation.
    """
    if all(g.full_name for op in transformer.operations or () for g in op.grids):
        return  # every grid it needs is on this host
    try:
        Transformer.from_pipeline(pipeline_text(transformer))
    except pyproj.exceptions.ProjError:
        raise InputError(missing_grid_message(target_text, group, transformer)) from None


def pipeline_text(transformer: Transformer) -> str:
    """A transformation's PROJ definition as a pipeline (``proj=pipeline step ...``).

    Parameters
    ----------
    transformer : Transformer
        The transformation.
    """
    text = str(transformer.definition)
    return text if text.startswith("proj=pipeline") else f"proj=pipeline step {text}"
