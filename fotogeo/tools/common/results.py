"""What the path tools return: frozen result objects with documented fields.

One model direction for the user: every result has a :class:`~fotogeo.geometry.georeference.Georeference`
(``georeference``) and the shortcuts :meth:`pixel_to_map` (image ``(col, row)``, corner
convention → map ``(X, Y)`` in the result's CRS) and :meth:`map_to_pixel` (the reverse),
whatever way the model was fitted. ``model`` is the fitted model itself, in the direction of
its fit — pixel → map for the 2-D registration, ground → pixel for the terrain-aware
registration and every orientation model — and is what ``model.to_dict()`` stores in the report.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...geometry.georeference import Georeference


class _OnTheMap:
    """``pixel_to_map`` / ``map_to_pixel`` through the result's ``georeference``."""

    georeference: Georeference

    def pixel_to_map(self, colrow) -> np.ndarray:
        """Map ``(X, Y)`` ``(N, 2)`` of image pixels ``(col, row)`` (corner convention), in :attr:`crs`."""
        return self.georeference.pixel_to_map(colrow)

    def map_to_pixel(self, XY) -> np.ndarray:
        """Image pixels ``(col, row)`` ``(N, 2)`` (corner convention) of map points ``(X, Y)`` in :attr:`crs`."""
        return self.georeference.map_to_pixel(XY)

    @property
    def crs(self):
        """The map CRS (:class:`pyproj.CRS`) of :meth:`pixel_to_map` and :meth:`map_to_pixel`."""
        return self.georeference.crs


@dataclass(frozen=True)
class Registration(_OnTheMap):
    """What :func:`fotogeo.register` produced.

    - ``output``, ``vectors``, ``report_path``: the registered raster, the GeoPackage (layers
      ``tie_points``, ``error_vectors``, ``error_grid``) and the JSON report;
    - ``model``: the fitted model, pixel → map in 2-D mode (``Projective`` …), ground → pixel
      with a DEM (``DLT``, ``RFM``, collinearity) — prefer ``georeference`` / :meth:`pixel_to_map` /
      :meth:`map_to_pixel`, which do not depend on it;
    - ``report``: the report dict (also written to ``report_path``): ``output_crs`` and
      ``output_crs_rule``, ``output_grid`` (``aligned_to_reference``), ``control`` / ``check``
      statistics, ``notes`` explaining every number;
    - ``georeference``: the target image ↔ the output CRS (heights from the DEM in 3-D mode).
    """

    output: Path
    vectors: Path
    report_path: Path
    model: object
    report: dict = field(repr=False)
    georeference: Georeference | None = field(default=None, repr=False)


@dataclass(frozen=True)
class Orientation(_OnTheMap):
    """What :func:`fotogeo.orient` produced.

    - ``model``: the fitted ground → pixel model; ``model_name`` its name (the chosen one for
      ``model="auto"``, with the candidates and the reason in ``report["model_selection"]``);
    - ``georeference``: image ↔ the GCPs' CRS, heights = the GCPs' mean height (3-D models);
    - ``report``: the report dict (``control`` / ``check`` / ``blunder`` statistics in pixels,
      ``points``, ``snooping``, ``warnings``, ``exaggeration``, ``notes``);
    - ``outputs``: ``{kind: path}`` of the files written (report, vectors, plot, …).

    For compatibility the result reads like its report: ``result["check"]``,
    ``result.get("blunder")``, ``"rpc" in result``; ``to_dict()`` is the report (what the QGIS
    worker sends back).
    """

    model: object
    georeference: Georeference = field(repr=False)
    report: dict = field(repr=False)
    outputs: dict = field(default_factory=dict)

    @property
    def model_name(self) -> str:
        return self.report["model_name"]

    def __getitem__(self, key):
        return self.report[key]

    def __contains__(self, key) -> bool:
        return key in self.report

    def get(self, key, default=None):
        return self.report.get(key, default)

    def keys(self):
        return self.report.keys()

    def to_dict(self) -> dict:
        return self.report
