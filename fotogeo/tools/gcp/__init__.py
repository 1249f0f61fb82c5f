"""The GCP picker's engine (the QGIS *GCP picker* calls these through the worker): quick refits,
prediction grids, the live preview, automatic candidates, ODM ``gcp_list.txt`` files.

* :mod:`.fit` — :func:`fit_gcps` (residuals, blunder flags) and :func:`sample_heights` (DEM heights);
* :mod:`.grids` — prediction grids of a fitted model;
* :mod:`.preview` — :func:`preview_warp`, the image warped onto the map canvas through the current fit;
* :mod:`.propose` — :func:`propose_gcps`, candidates from an image against a georeferenced reference;
* :mod:`.files` — :func:`read_image_gcps` / :func:`write_image_gcps`, one image's measurements in and out.

The names above are loaded on first use (PEP 562): importing one module of the package does not import
the others."""

from ..common.lazy import lazy_getattr

_MODULES = {"fit_gcps": "fit", "sample_heights": "fit", "preview_warp": "preview", "propose_gcps": "propose",
            "read_image_gcps": "files", "write_image_gcps": "files"}
__all__ = sorted(_MODULES)
__getattr__ = lazy_getattr(__name__, _MODULES)
