"""An image placed on the map: a fitted model, the heights it needs and the map CRS.

One direction convention for every tool: **pixel** = ``(col, row)`` of the image (GDAL corner
convention, :mod:`fotogeo.pixels`), **map** = ``(X, Y)`` in :attr:`Georeference.crs`.

* :meth:`Georeference.pixel_to_map` — image → map: footprints, ground sample distances, where
  a measured image point lands on the ground (error vectors);
* :meth:`Georeference.map_to_pixel` — map → image: what resampling needs (each output grid
  cell's centre → the image pixel to sample), and where a ground point appears in the image.

The model may have been fitted either way, which ``direction`` records (it is a property of
the fit, so it may be given here; left out, it is the model's own ``direction`` — the RFM
classes carry one, the ``-i2g`` ones ``"image-to-ground"`` — else ``"ground-to-image"``):

* ``"ground-to-image"`` — ``model.forward`` maps map ``(X, Y[, Z])`` → pixel
  (orientation from GCPs, terrain-aware registration, RFM/RPC, collinearity);
* ``"image-to-ground"`` — ``model.forward`` maps pixel ``(col, row[, Z])`` → map (the planar
  registration; an ``-i2g`` RFM fitted with ``src = (col, row, Z)``).

``heights`` completes the source points of 3-D models (``src_dims = 3``) and is ignored by
2-D ones: a number, an ``(N,)`` array (one per point passed) or a
:class:`~fotogeo.geometry.dem.HeightSource` (a DEM; pixel → map then intersects the terrain,
map → pixel samples it at ``(X, Y)``).

>>> import numpy as np
>>> from fotogeo.models import Affine
>>> px = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
>>> geo = Georeference(Affine.estimate(px, px * 2 + 100), direction="image-to-ground")
>>> geo.pixel_to_map([[5.0, 5.0]]).round(6).tolist(), geo.map_to_pixel([[110.0, 110.0]]).round(6).tolist()
([[110.0, 110.0]], [[5.0, 5.0]])
>>> round(geo.ground_sample_distance(10, 10), 6)
2.0
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..pixels import as_points, outline
from .dem import heights_at, is_height_source

DIRECTIONS = ("ground-to-image", "image-to-ground")


@dataclass(frozen=True)
class Georeference:
    """``model`` + ``heights`` + ``crs``: pixel ↔ map whatever the model's direction and dimensionality."""

    model: object
    heights: object = None
    crs: object = None
    direction: str | None = None

    def __post_init__(self):
        if self.direction is None:
            object.__setattr__(self, "direction", getattr(self.model, "direction", "ground-to-image"))
        if self.direction not in DIRECTIONS:
            raise InputError(f"direction {self.direction!r} unknown; choose one of {', '.join(DIRECTIONS)}")

    @property
    def is_3d(self) -> bool:
        """Whether the model's source points carry a height (``src_dims == 3``)."""
        return getattr(self.model, "src_dims", 2) == 3

    def with_heights(self, heights) -> Georeference:
        """The same georeference with other ``heights``."""
        return replace(self, heights=heights)

    def pixel_to_map(self, colrow) -> np.ndarray:
        """Map ``(X, Y)`` ``(N, 2)`` of image pixels ``colrow`` ``(N, 2)``; NaN where there is none."""
        px = as_points(colrow, 2, "pixel coordinates")
        if self.direction == "ground-to-image":
            return self.model.inverse(px, self.heights)[:, :2]  # 2-D models ignore the heights
        if not self.is_3d:
            return self.model.forward(px)
        if not is_height_source(self.heights):
            return self.model.forward(np.column_stack([px, heights_at(self.heights, px)]))
        return self._forward_on_terrain(px)

    def map_to_pixel(self, XY) -> np.ndarray:
        """Image pixels ``(col, row)`` ``(N, 2)`` of map points ``XY`` ``(N, 2)``."""
        XY = as_points(XY, 2, "map coordinates")
        if self.direction == "ground-to-image":
            if self.is_3d:
                return self.model.forward(np.column_stack([XY, heights_at(self.heights, XY)]))
            return self.model.forward(XY)
        if self.is_3d:  # image-to-ground in (col, row, Z): invert at the height of the map point
            return self.model.inverse(XY, heights_at(self.heights, XY))[:, :2]
        return self.model.inverse(XY)

    def footprint(self, width: int, height: int, n: int = 33) -> np.ndarray:
        """Map ``(X, Y)`` of the outline of a ``width x height`` image (``n`` points per edge,
        :func:`fotogeo.pixels.outline`); NaN where the model gives no ground point."""
        return self.pixel_to_map(outline(width, height, n))

    def ground_sample_distance(self, width: int, height: int) -> float:
        """Ground size of one image pixel at the image centre, ``sqrt(|u × v|)`` in map units.

        ``u`` and ``v`` are the map steps of one pixel along a row and along a column from the
        centre ``(width / 2, height / 2)``; for non-square pixels this is the side of the
        square of the same area.
        """
        c = np.array([[width / 2, height / 2], [width / 2 + 1, height / 2], [width / 2, height / 2 + 1]])
        p = self.pixel_to_map(c)
        u, v = p[1] - p[0], p[2] - p[0]
        return float(np.sqrt(abs(u[0] * v[1] - u[1] * v[0])))

    def _forward_on_terrain(self, px, iterations: int = 30, tol_z: float = 1e-4) -> np.ndarray:
        """Image -> ground model on a DEM: ``XY = f(col, row, Z)``, ``Z = h(XY)`` by fixed point
        (:func:`intersect_terrain`: only the points not yet converged are iterated)."""
        z0 = np.full(len(px), float(self.model.src_norm.offset[2]))
        return intersect_terrain(lambda idx, z, start: self.model.forward(np.column_stack([px[idx], z])),
                                 lambda XY: heights_at(self.heights, XY), z0, iterations, tol_z)


def intersect_terrain(solve, height_of, z0, iterations: int = 30, tol_z: float = 1e-4) -> np.ndarray:
    """Ground points of image points on the terrain, by fixed point on the height, iterating
    only the points still moving (an active set).

    ``solve(idx, Z, start)`` gives the ground points ``(len(idx), >= 2)`` (``X, Y`` first) of
    the image points ``idx`` at heights ``Z`` (``start``: their previous ground points, a
    starting value for iterative solvers, or ``None`` at step 0); ``height_of(XY)`` the
    terrain heights ``(N,)`` (NaN off the terrain). Step 0: ``P_0 = solve(Z_0 = z0)``; step k:
    ``Z_k = h(XY_{k-1})``, ``P_k = solve(Z_k, start=P_{k-1})``. A point converges at the step
    where ``|Z_k - Z_{k-1}| < tol_z`` (or ``Z_k`` is NaN: off the terrain) and keeps ``P_k``;
    the others go on, at most ``iterations`` steps. A point's answer therefore does not depend
    on the other points solved with it. Used by :meth:`Georeference.pixel_to_map` for
    image -> ground models and by the inverse of the ground -> image 3-D models
    (:meth:`fotogeo.models.spatial.FittedModel.inverse`).
    """
    z = np.array(z0, dtype=np.float64)
    active = np.arange(len(z))
    out = np.array(solve(active, z, None), dtype=np.float64)
    for _ in range(iterations):
        if active.size == 0:
            break
        z_new = height_of(out[active, :2])
        out[active] = solve(active, z_new, out[active])
        moving = np.abs(z_new - z[active]) >= tol_z  # False for NaN: off the terrain, done
        z[active] = z_new
        active = active[moving]
    return out
