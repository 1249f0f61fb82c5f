"""Orthophotos and mosaics (``fotogeo ortho``, ``fotogeo mosaic``).

* :mod:`.tool` — :func:`ortho`, images with a known orientation onto a DEM (occlusion, uncertainty);
* :mod:`.inputs` — each image's ground → image model, the map CRS and the heights;
* :mod:`.products` — the rasters beside each orthophoto (σ, visibility);
* :mod:`.mosaic` — :func:`mosaic`, seamlines, feathering and balancing;
* :mod:`.mosaic_tiles` — the mosaic's blending in tiles (threads or Dask tasks).

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"ortho": "tool", "mosaic": "mosaic"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
