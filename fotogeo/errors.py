"""The one error hierarchy of fotogeo.

Every error fotogeo raises on purpose derives from :class:`FotogeoError`, and from the
built-in exception a Python user would expect (``ValueError`` for bad values, ``OSError``
for files). Messages name the offending input and say how to fix it; the CLI and the QGIS
provider show them as they are, without a traceback.
"""
from __future__ import annotations


class FotogeoError(Exception):
    """Base class of every error fotogeo raises deliberately."""


class InputError(FotogeoError, ValueError):
    """An input value, array or parameter is invalid (names it and says what would be valid)."""


class RasterError(FotogeoError, OSError):
    """A raster cannot be read or lacks what the operation needs (e.g. a georeference)."""


class VectorError(FotogeoError, OSError):
    """A vector layer or points file cannot be read or lacks what the operation needs."""


class OutputError(FotogeoError, OSError):
    """An output cannot be written (exists without overwrite, equals an input, folder missing)."""


class MatchingError(FotogeoError, RuntimeError):
    """Images could not be matched: too few keypoints, matches or inliers (says how many)."""


class ModelError(FotogeoError, ValueError):
    """A geometric model cannot be estimated: too few points, degenerate or ill-posed geometry."""


class Cancelled(FotogeoError):
    """The progress callback asked to stop; no partial output is left behind."""


class FotogeoWarning(UserWarning):
    """Base class of fotogeo's warnings: a result was produced but deserves caution."""


class IllPosedWarning(FotogeoWarning):
    """A model was estimated but is poorly determined (flat terrain, too few or clustered points)."""
