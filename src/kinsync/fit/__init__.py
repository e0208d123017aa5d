"""Sphere fitting for targets (SPEC section 2).

- `kinsync.fit.sphere`: `fit_sphere_algebraic` (closed-form Hyper fit) and
  `fit_sphere` (Levenberg-Marquardt on the orthogonal or the ray residual, with the
  centre covariance), returning a `SphereFit`.
- `kinsync.fit.segment`: `segment_sphere`, RANSAC and a robust refinement that find the
  sphere among clutter.
"""

from kinsync.fit.segment import segment_sphere
from kinsync.fit.sphere import SphereFit, fit_sphere, fit_sphere_algebraic

__all__ = ["SphereFit", "fit_sphere", "fit_sphere_algebraic", "segment_sphere"]
