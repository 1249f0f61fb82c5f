"""Local features: fotogeo's own SURF (OpenCV wheels exclude it) and descriptor matching.

:func:`surf` returns a :class:`SurfResult` (positions in the GDAL corner convention).
"""
from .match import Matches, match_descriptors
from .surf import SurfResult, surf

__all__ = ["Matches", "SurfResult", "match_descriptors", "surf"]
