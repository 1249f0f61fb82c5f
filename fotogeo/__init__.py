"""fotogeo — aerial and satellite images to map-accurate data.

Layers: arrays and models (:mod:`fotogeo.fusion`, :mod:`fotogeo.features`,
:mod:`fotogeo.models`, ...) → path tools (:mod:`fotogeo.register`, ...) → the ``fotogeo``
command line (:mod:`fotogeo.cli`) → the QGIS Processing provider (``processing_provider``).
"""
__version__ = "0.1.0"

from .errors import (Cancelled, FotogeoError, InputError, MatchingError, ModelError,  # noqa: F401
                     OutputError, RasterError, VectorError)
