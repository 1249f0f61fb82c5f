"""fotogeo — aerial and satellite images to map-accurate data.

Layers (see DESIGN.md): arrays and models (:mod:`fotogeo.image`, :mod:`fotogeo.geometry`,
:mod:`fotogeo.features`, :mod:`fotogeo.matching`, :mod:`fotogeo.models`,
:mod:`fotogeo.orientation`) → file formats (:mod:`fotogeo.io`) → path tools
(:mod:`fotogeo.tools`) → the ``fotogeo`` command line (:mod:`fotogeo.cli`) → the QGIS
Processing provider (``processing_provider``).

The tools are importable from here (loaded on first use, so ``import fotogeo`` stays light)::

    >>> import fotogeo
    >>> fotogeo.register.__module__
    'fotogeo.tools.register'
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

__version__ = "0.1.0"

#: public tool functions: name -> module under fotogeo.tools
_TOOLS = {"register": "register", "match_images": "match", "orient": "orient", "compare_models": "compare",
          "fuse_raster": "fuse", "transfer_gcps": "transfer", "measure_targets": "targets",
          "points_to_layer": "points", "layer_to_points": "points", "run_demo": "demo", "rpc_bias": "rpc_bias"}

__all__ = ["__version__", "FotogeoError", "FotogeoWarning", "InputError", "RasterError", "VectorError",
           "OutputError", "MatchingError", "ModelError", "Cancelled", "IllPosedWarning", *_TOOLS]


def __getattr__(name: str):
    if name in _TOOLS:
        value = getattr(importlib.import_module(f".tools.{_TOOLS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fotogeo' has no attribute {name!r}")
