"""Residuals on a plane about each line's own robust fit of it, in one compiled loop.

`kinsync.calibration.adjustment` weights a plane's returns by Tukey's biweight of
their residuals about their own line's fit of the plane (offset and two tilts): a line
that sits a few centimetres off, or drifts across the plane, keeps its weight, while a
car or a bush stays off the line's fit. That fit runs for every line on every plane at
every state of the adjustment and of each of the jackknife's deleted-line solutions:
thousands of small reweighted least-squares problems. One Python loop with numpy calls
per line spent 45 % of `calibrate mount` there (16 lines: 17 of 38 s, profiled), and
held the interpreter lock, so the jackknife's threads ran one at a time. This module
is the same loop compiled by numba (``nogil``): per line, the median-centred
residuals, then `iterations` fits reweighted by Tukey's biweight at the line's own
robust scale (``1.4826 MAD``), each solved by the same LAPACK least-squares routine as
``numpy.linalg.lstsq`` (``gelsd``, ``rcond`` = machine epsilon x rows).

References
----------
Holland, P. W. & Welsch, R. E., "Robust regression using iteratively reweighted
least-squares", Commun. Stat. Theory Methods 6(9), 1977, 813-827.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import cast

import numpy as np

from kinsync._jit import cached_njit
from kinsync._typing import BoolArray, FloatArray, IntArray
from kinsync.robust import MAD_TO_SIGMA, robust_sigma

__all__ = ["detrend_lines", "detrend_lines_numpy"]

_EPS = float(np.finfo(np.float64).eps)


def _detrend_loop(  # noqa: PLR0912 - one flat loop is what numba compiles best
    e: FloatArray,
    good: BoolArray,
    jac: FloatArray,
    cuts: IntArray,
    min_fit: int,
    iterations: int,
    tukey_c: float,
    min_scale_m: float,
    mad_to_sigma: float,
) -> FloatArray:  # pragma: no cover - compiled by numba; its results are tested
    """The loop of `detrend_lines` (see there); compiled below."""
    out = e.copy()
    for s in range(cuts.size - 1):
        a = cuts[s]
        b = cuts[s + 1]
        n = b - a
        n_good = 0
        for i in range(a, b):
            if good[i]:
                n_good += 1
        if n_good == 0:
            continue
        vals = np.empty(n_good)
        j = 0
        for i in range(a, b):
            if good[i]:
                vals[j] = e[i]
                j += 1
        med = np.median(vals)
        r = e[a:b] - med
        if n_good >= min_fit:
            block = np.ascontiguousarray(jac[a:b])
            for _ in range(iterations):
                j = 0
                for i in range(n):
                    if good[a + i]:
                        vals[j] = abs(r[i])
                        j += 1
                scale = max(mad_to_sigma * np.median(vals), min_scale_m)
                weighted = np.zeros((n, 3))
                rhs = np.zeros(n)
                n_weighted = 0
                for i in range(n):
                    if good[a + i]:
                        u = r[i] / scale
                        if abs(u) < tukey_c:
                            z = u / tukey_c
                            root = np.sqrt((1.0 - z * z) ** 2)
                            if root != 0.0:
                                n_weighted += 1
                            for c in range(3):
                                weighted[i, c] = block[i, c] * root
                            rhs[i] = -e[a + i] * root
                if n_weighted < min_fit:
                    break
                step = np.linalg.lstsq(weighted, rhs, _EPS * max(n, 3))[0]
                r = e[a:b] + block @ step
        out[a:b] = r
    return out


def _line_cuts(group: IntArray) -> IntArray:
    """Where each line's run of returns starts, and the end: shape (lines + 1,)."""
    g = np.asarray(group)
    cuts: IntArray = np.concatenate(([0], np.flatnonzero(g[1:] != g[:-1]) + 1, [g.size]))
    return cuts.astype(np.int64)


_detrend_kernel = cast(Callable[..., FloatArray], cached_njit(nogil=True)(_detrend_loop))


def detrend_lines(
    e_m: FloatArray,
    good: BoolArray,
    jacobian: FloatArray,
    group: IntArray,
    *,
    min_fit: int,
    iterations: int,
    tukey_c: float,
    min_scale_m: float,
) -> FloatArray:
    """Residuals about each line's own robust fit of the plane.

    Each line (a run of equal ``group``) with at least ``min_fit`` good returns gets
    its own offset and tilt, fitted by least squares reweighted with Tukey's biweight
    (``iterations`` times, from the line's median; stopped early when fewer than
    ``min_fit`` returns keep a weight); a line with fewer good returns is centred on
    its median; a line with none is left as it is.

    Parameters
    ----------
    e_m : ndarray, shape (n,)
        Residuals: signed distances to the plane (m); 0 where not ``good``.
    good : ndarray of bool, shape (n,)
        Returns that take part (their position is finite).
    jacobian : ndarray, shape (n, 3)
        ``d e / d (tilt_u, tilt_w, offset)`` of each return (`PlaneFeature.jacobian`).
    group : ndarray of int, shape (n,)
        Each return's line; a line's returns in one run.
    min_fit : int
        Good returns a line needs for its own fit.
    iterations : int
        Reweighted fits per line.
    tukey_c : float
        Tukey's biweight constant, in units of the line's robust scale.
    min_scale_m : float
        Floor of the line's robust scale (m).

    Returns
    -------
    ndarray, shape (n,)
        Residuals about the line's fit (m); about its median where it has too few good
        returns.
    """
    cuts = _line_cuts(group)
    return _detrend_kernel(
        np.ascontiguousarray(e_m, dtype=np.float64),
        np.ascontiguousarray(good, dtype=np.bool_),
        np.ascontiguousarray(jacobian, dtype=np.float64),
        cuts,
        int(min_fit),
        int(iterations),
        float(tukey_c),
        float(min_scale_m),
        MAD_TO_SIGMA,
    )


def detrend_lines_numpy(
    e_m: FloatArray,
    good: BoolArray,
    jacobian: FloatArray,
    group: IntArray,
    *,
    min_fit: int,
    iterations: int,
    tukey_c: float,
    min_scale_m: float,
) -> FloatArray:
    """`detrend_lines` as a plain numpy loop: the reference it is tested and timed against.

    The loop `kinsync.calibration.adjustment` ran before it was compiled (one
    ``numpy.linalg.lstsq`` per line and iteration).

    Parameters
    ----------
    e_m, good, jacobian, group, min_fit, iterations, tukey_c, min_scale_m
        As `detrend_lines`.

    Returns
    -------
    ndarray, shape (n,)
        As `detrend_lines`.
    """
    out = e_m.copy()
    for on in itertools.starmap(slice, itertools.pairwise(_line_cuts(group).tolist())):
        ok = good[on]
        if not np.any(ok):
            continue
        r = e_m[on] - float(np.median(e_m[on][ok]))
        if np.count_nonzero(ok) >= min_fit:
            for _ in range(iterations):
                scale = max(robust_sigma(r[ok]), min_scale_m)
                u = r / scale
                w = np.where(np.abs(u) < tukey_c, (1.0 - (u / tukey_c) ** 2) ** 2, 0.0)
                root = np.sqrt(np.where(ok, w, 0.0))
                if np.count_nonzero(root) < min_fit:
                    break
                step, *_ = np.linalg.lstsq(
                    jacobian[on] * root[:, None], -e_m[on] * root, rcond=None
                )
                r = e_m[on] + jacobian[on] @ step
        out[on] = r
    return out
