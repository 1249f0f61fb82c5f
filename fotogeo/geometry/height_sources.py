"""Height sources that are not a DEM on a grid: a constant height, a callable ``XY -> heights`` (its gradient by
central differences) and a source whose height bracket is hidden (:func:`below`); :func:`as_height_source` wraps any
of them (and a :class:`~fotogeo.geometry.dem.Dem`) as a :class:`~fotogeo.geometry.dem.HeightSource` (the protocol's
module doc). Moved out of :mod:`fotogeo.geometry.dem`, which re-exports them."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


def as_height_source(dem) -> "HeightSource":
    """Wrap ``dem`` into a :class:`~fotogeo.geometry.dem.HeightSource` (an object with ``heights_and_gradient(XY)``).

    Accepts a :class:`~fotogeo.geometry.dem.Dem` (or anything with ``heights_and_gradient``), any object with a
    ``heights(XY)`` method or a callable ``XY -> heights`` (gradient by central differences
    with a 1 map-unit step), or a number (a constant height).
    """
    if hasattr(dem, "heights_and_gradient"):
        return dem
    if isinstance(dem, (int, float, np.floating, np.integer)):
        return _Constant(float(dem))
    f = getattr(dem, "heights", dem)
    if not callable(f):
        raise InputError("dem must be a fotogeo.geometry.dem.Dem, an object with heights(XY), a callable "
                         f"XY -> heights or a constant height; got {type(dem).__name__}")
    return _Sampled(f)


def below(heights, z: float) -> "HeightSource":
    """``heights`` as a :class:`~fotogeo.geometry.dem.HeightSource`, without its ``z_range`` when that reaches the height ``z`` of a
    projection centre: :meth:`~fotogeo.geometry.camera.OrientedFrame.pixel_to_world` then intersects the rays
    below the centre only (as for a sampler of unknown relief) instead of refusing the whole DEM because one hill
    somewhere — a regional DEM around a drone block 100 m over a valley — rises above the camera."""
    src = as_height_source(heights)
    if not hasattr(src, "z_range") or src.z_range[1] < z:
        return src
    return _Unbounded(src)


@dataclass(frozen=True)
class _Constant:
    z: float

    @property
    def z_range(self) -> tuple[float, float]:
        return self.z, self.z

    def heights_and_gradient(self, XY):
        n = len(XY)
        return np.full(n, self.z), np.zeros(n), np.zeros(n)


@dataclass(frozen=True)
class _Sampled:
    f: object
    step: float = 1.0

    def heights_and_gradient(self, XY):
        XY = np.asarray(XY, dtype=np.float64)
        e = self.step
        h = np.asarray(self.f(XY), dtype=np.float64).reshape(-1)
        gx = (np.asarray(self.f(XY + [e, 0])) - np.asarray(self.f(XY - [e, 0]))).reshape(-1) / (2 * e)
        gy = (np.asarray(self.f(XY + [0, e])) - np.asarray(self.f(XY - [0, e]))).reshape(-1) / (2 * e)
        return h, gx, gy


@dataclass(frozen=True)
class _Unbounded:
    """A height source hiding the ``z_range`` of ``source`` (:func:`below`)."""
    source: object

    def heights_and_gradient(self, XY):
        return self.source.heights_and_gradient(XY)
