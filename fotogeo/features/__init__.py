"""Local features: fotogeo's own SURF (OpenCV wheels exclude it) and descriptor matching.

:func:`surf` returns a :class:`SurfResult` (positions in the GDAL corner convention).
"""
from .surf import SurfResult, surf  # noqa: F401

__all__ = ["surf", "SurfResult"]
