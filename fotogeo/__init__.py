"""fotogeo — aerial and satellite images to map-accurate data.

Layers (see DESIGN.md): arrays and models (:mod:`fotogeo.image`, :mod:`fotogeo.geometry`,
:mod:`fotogeo.features`, :mod:`fotogeo.matching`, :mod:`fotogeo.models`,
:mod:`fotogeo.orientation`) → file formats (:mod:`fotogeo.io`) → path tools
(:mod:`fotogeo.tools`) → the ``fotogeo`` command line (:mod:`fotogeo.cli`) → the QGIS
Processing provider (``processing_provider``).

The Python façade: the tools and their result objects are importable from here (loaded on
first use, so ``import fotogeo`` stays light). Paths in, paths out; every tool takes
``overwrite=`` and ``progress=`` (a callback ``progress(fraction, message) -> bool``, False
cancels) and raises :class:`FotogeoError` s naming the input and the fix.

- :func:`register` → :class:`Registration` (``output``, ``vectors``, ``report_path``,
  ``model``, ``report``, ``georeference``);
- :func:`orient` → :class:`Orientation` (``model``, ``model_name``, ``georeference``,
  ``report``, ``outputs``; ``result["check"]`` reads the report);
- both results map pixels and map coordinates the same way, whatever direction the model was
  fitted in: ``pixel_to_map((col, row))`` / ``map_to_pixel((X, Y))``, corner convention
  (``(0, 0)`` = top-left corner of the top-left pixel), in ``result.crs``.

A registration from tie points given by hand (no matching), on a tiny scene written to a
temporary folder — the target is the reference shifted by (3, 2) pixels::

    >>> import tempfile, pathlib, numpy as np, rasterio
    >>> from rasterio.transform import from_origin
    >>> import fotogeo
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.random.default_rng(0).integers(1, 255, (1, 80, 80), dtype="uint8")
    >>> with rasterio.open(d / "ref.tif", "w", driver="GTiff", width=80, height=80, count=1, dtype="uint8",
    ...                    crs="EPSG:32635", transform=from_origin(500000, 4400000, 10, 10)) as ds:
    ...     ds.write(img)
    >>> with rasterio.open(d / "tgt.tif", "w", driver="GTiff", width=80, height=80, count=1, dtype="uint8") as ds:
    ...     ds.write(img)
    >>> ref_px = np.stack(np.meshgrid(np.arange(8, 72, 6.0), np.arange(8, 72, 6.0)), -1).reshape(-1, 2)
    >>> r = fotogeo.register(d / "ref.tif", d / "tgt.tif", d / "out.tif", tie_points=(ref_px - [3, 2], ref_px),
    ...                      model="affine")
    >>> r.pixel_to_map([[0.0, 0.0]]).round(3).tolist()   # target (0, 0) is reference (3, 2)
    [[500030.0, 4399980.0]]
    >>> r.map_to_pixel([[500030.0, 4399980.0]]).round(3).tolist()
    [[0.0, 0.0]]
    >>> r.report["output_crs_rule"], r.report["output_grid"]["aligned_to_reference"]
    ("auto: the reference's CRS (it is projected)", True)
    >>> sorted(r.report["notes"])[:3]
    ['check', 'control', 'exaggeration']

An orientation from GCPs in a CSV file, the model chosen by ``auto``::

    >>> gcp = d / "gcps.csv"
    >>> cr = np.random.default_rng(1).uniform(5, 75, (12, 2))
    >>> _ = gcp.write_text("id,col,row,x,y\\n" + "".join(
    ...     f"P{i},{c:.4f},{w:.4f},{500000 + 10 * c:.4f},{4400000 - 10 * w:.4f}\\n" for i, (c, w) in enumerate(cr)))
    >>> o = fotogeo.orient(d / "tgt.tif", gcp, model="auto", crs="EPSG:32635")
    >>> o.model_name, o["model_selection"]["candidates"][0]["model"]
    ('similarity', 'similarity')
    >>> o.map_to_pixel([[500100.0, 4399900.0]]).round(3).tolist()
    [[10.0, 10.0]]
"""
from __future__ import annotations

import importlib

from .errors import (  # noqa: F401
    Cancelled,
    FotogeoError,
    FotogeoWarning,
    IllPosedWarning,
    InputError,
    MatchingError,
    ModelError,
    OutputError,
    RasterError,
    VectorError,
)


#: public tool functions: name -> module under fotogeo.tools
_TOOLS = {"register": "register.tool", "match_images": "register.match", "orient": "orient.tool",
          "compare_models": "orient.compare", "fuse_raster": "register.fuse", "transfer_gcps": "points.transfer",
          "measure_targets": "points.targets", "points_to_layer": "points.layers", "layer_to_points": "points.layers",
          "run_demo": "demo.tool", "rpc_bias": "orient.rpc_bias", "register_batch": "register.batch",
          "triangulate": "triangulate", "interior": "interior.tool", "ortho": "ortho.tool", "mosaic": "ortho.mosaic",
          "dsm": "dsm.tool"}
#: public classes loaded on first use: name -> module under fotogeo
_CLASSES = {"Registration": "tools.common.results", "Orientation": "tools.common.results", "RegisterOptions": "options",
            "Georeference": "geometry.georeference"}

__all__ = ["__version__", "FotogeoError", "FotogeoWarning", "InputError", "RasterError", "VectorError",
           "OutputError", "MatchingError", "ModelError", "Cancelled", "IllPosedWarning", *_TOOLS, *_CLASSES]


def __getattr__(name: str):
    if name == "__version__":  # read on first use (an installed package's costs importlib.metadata's import)
        from ._version import version
        globals()[name] = value = version()
        return value
    if name in _TOOLS or name in _CLASSES:
        module = f".tools.{_TOOLS[name]}" if name in _TOOLS else f".{_CLASSES[name]}"
        value = getattr(importlib.import_module(module, __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fotogeo' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
