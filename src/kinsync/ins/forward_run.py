"""What the forward filter hands to the RTS smoother: the checkpoints and the run.

The forward pass (`kinsync.ins.filter`) stores a compact *checkpoint* at each GNSS
update (the prior and posterior covariance, the accepted rows of ``H``, their
variances and ``z``) and a plain one (no update) at the initial epoch and every
`CHECKPOINT_EVERY` epochs; `kinsync.ins.smoother` recomputes ``Φ`` and the
covariances between checkpoints from the stored nominal states. The compiled loop
writes into a preallocated `CheckpointStore`; `checkpoints_from_store` trims it to the
frozen `Checkpoints` the smoother reads. Neither module imports the other: both
import this one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from kinsync._arrays import ReadOnlyArrays
from kinsync._typing import FloatArray, IntArray
from kinsync.ins.gnss_observation import MAX_ROWS

__all__ = [
    "CHECKPOINT_EVERY",
    "CheckpointStore",
    "Checkpoints",
    "ForwardRun",
    "checkpoints_from_store",
    "new_checkpoint_store",
]

CHECKPOINT_EVERY = 2_000
"""Longest run of IMU epochs between two smoother checkpoints."""


@dataclass(frozen=True, eq=False)
class Checkpoints(ReadOnlyArrays):
    """What the smoother needs from the forward pass (see the module docstring).

    Attributes
    ----------
    epoch : ndarray of int, shape (c,)
        IMU epoch of each checkpoint (non-decreasing; the first is the initial epoch).
    P_minus, P_plus : ndarray, shape (c, n, n)
        Error covariance before and after the checkpoint's update.
    H : ndarray, shape (c, 6, n)
        Observation rows (the first ``nrows`` are used).
    r : ndarray, shape (c, 6)
        Their noise variances.
    z : ndarray, shape (c, 6)
        Their values (INS minus GNSS; the innovation, as the prior error is zero).
    nrows : ndarray of int, shape (c,)
        Rows used (0: no update, a plain checkpoint).
    """

    epoch: IntArray
    P_minus: FloatArray
    P_plus: FloatArray
    H: FloatArray
    r: FloatArray
    z: FloatArray
    nrows: IntArray


class CheckpointStore(NamedTuple):
    """Preallocated checkpoints, filled in place by the compiled forward loop.

    A tuple of arrays (and two scalars) so that numba compiles it; the array fields
    have the layout of `Checkpoints` with room for ``capacity`` rows, of which the
    first ``n_filled[0]`` are filled.

    Attributes
    ----------
    enabled : bool
        Store checkpoints at all (smoothing requested); when False the arrays have one
        row and are never written.
    every_epochs : int
        Longest run of IMU epochs between two checkpoints.
    n_filled : ndarray of int, shape (1,)
        Checkpoints stored so far.
    last_epoch : ndarray of int, shape (1,)
        IMU epoch of the last checkpoint stored.
    epoch, P_minus, P_plus, H, r, z, nrows
        As in `Checkpoints`, shapes (capacity, ...).
    """

    enabled: bool
    every_epochs: int
    n_filled: IntArray
    last_epoch: IntArray
    epoch: IntArray
    P_minus: FloatArray
    P_plus: FloatArray
    H: FloatArray
    r: FloatArray
    z: FloatArray
    nrows: IntArray


def new_checkpoint_store(
    capacity: int, every_epochs: int, n_err: int, *, enabled: bool
) -> CheckpointStore:
    """Empty store for ``capacity`` checkpoints of ``n_err`` error states.

    One unused row when not ``enabled``.
    """
    c = capacity if enabled else 1
    return CheckpointStore(
        enabled=enabled,
        every_epochs=every_epochs,
        n_filled=np.zeros(1, dtype=np.int64),
        last_epoch=np.zeros(1, dtype=np.int64),
        epoch=np.zeros(c, dtype=np.int64),
        P_minus=np.zeros((c, n_err, n_err)),
        P_plus=np.zeros((c, n_err, n_err)),
        H=np.zeros((c, MAX_ROWS, n_err)),
        r=np.zeros((c, MAX_ROWS)),
        z=np.zeros((c, MAX_ROWS)),
        nrows=np.zeros(c, dtype=np.int64),
    )


def checkpoints_from_store(store: CheckpointStore) -> Checkpoints | None:
    """The filled part of ``store`` (views, not copies); None when it was not enabled."""
    if not store.enabled:
        return None
    c = int(store.n_filled[0])
    return Checkpoints(
        epoch=store.epoch[:c],
        P_minus=store.P_minus[:c],
        P_plus=store.P_plus[:c],
        H=store.H[:c],
        r=store.r[:c],
        z=store.z[:c],
        nrows=store.nrows[:c],
    )


@dataclass(frozen=True, eq=False)
class ForwardRun(ReadOnlyArrays):
    """Raw output of the forward pass (internal; the smoother reads it).

    Attributes
    ----------
    k0 : int
        Initial IMU epoch; arrays below are indexed by absolute IMU epoch.
    states : ndarray, shape (n, 31)
        Nominal states after feedback (rows before ``k0`` unused).
    std : ndarray, shape (n, 21)
        1σ of the error state.
    params : ndarray
        Parameter vector of the loop.
    checkpoints : Checkpoints or None
    n_error_states : int
        Size of the error state the filter ran with: 21, or 27 with scale factors,
        plus one after a levelled standstill (`kinsync.ins.standstill`).
    """

    k0: int
    states: FloatArray
    std: FloatArray
    params: FloatArray
    checkpoints: Checkpoints | None
    n_error_states: int
