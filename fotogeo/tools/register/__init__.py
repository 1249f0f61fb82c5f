"""Registration of an image to a georeferenced reference (``fotogeo register``, ``match``, ``fuse``,
``register-batch``): PCA band fusion, feature matching, robust model fit, sub-pixel refinement.

* :mod:`.tool` — :func:`register`, the tool (reference + target → georeferenced raster, vectors, report);
* :mod:`.points` — the tie points: matched, refined by least-squares matching, weighted;
* :mod:`.local` — area-based windows inside the registration (the co-registration's engine);
* :mod:`.coarse` — an unreferenced target pre-aligned by a Fourier–Mellin similarity for those windows;
* :mod:`.bands` — the images LSM refines on, made to correspond across band sets;
* :mod:`.report` — the registration report and its summary lines;
* :mod:`.match` — :func:`match_images`, matching only (keypoints, descriptors, optional LSM);
* :mod:`.fuse` — :func:`fuse_raster`, PCA band fusion of a multi-band raster;
* :mod:`.batch` — :func:`register_batch`, many scenes to one reference as Dask tasks.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"register": "tool", "match_images": "match", "fuse_raster": "fuse", "register_batch": "batch"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
