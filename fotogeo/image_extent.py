"""Whether a pixel position lies on an image: the one rule of every tool fitting to GCPs
(:func:`fotogeo.io.gcps.skip_outside`), of the fit telling a copy's reading from a crop's
(:mod:`fotogeo.orientation.copy_reading`) and of the QGIS GCP picker's click guard: in the ground layer, below the
array layers and the file formats that both use it.

In the corner convention (:mod:`fotogeo.pixels`: ``(0, 0)`` the top-left corner of the top-left pixel) a position
``(col, row)`` lies on a ``width`` x ``height`` image when ``0 <= col <= width`` and ``0 <= row <= height``: the
image's edges and corners included. Standard library only — the QGIS plugin imports it in QGIS's own Python, where
fotogeo's numpy code is not loaded — and written with the operators ``>=``, ``<=`` and ``&`` so that the same
function takes numbers (a bool) or numpy arrays (element by element).
"""
from __future__ import annotations


def on_image(col, row, width, height):
    """True where ``(col, row)`` lies on the ``width`` x ``height`` image, edges included (module docstring); NaN
    lies nowhere. Numbers give a bool, arrays a boolean array."""
    return (col >= 0) & (col <= width) & (row >= 0) & (row <= height)


def outside_reason(width: int, height: int) -> str:
    """The one wording of a position off the image (warnings, reports' ``skipped``, the QGIS picker)."""
    return f"outside the image ({width}x{height} px)"
