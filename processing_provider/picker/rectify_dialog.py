"""The picker's Rectify options and the folder its file dialogs open in.

*Rectify…* asks what the Georeferencer's transformation settings ask: the output file, the
resampling, the pixel size (default: the image's ground sample distance from the fit, rounded to a
round number by :func:`round_size`; 0: the exact GSD) and the output CRS (default: the map's, its
horizontal part when it is a compound CRS with heights; another CRS than the GCP layer's gets the GCPs
transformed into it before the fit, so the image is resampled once, straight onto the chosen grid). File dialogs start in the folder last used by the picker, else
beside the image — not in the home folder.
"""
from __future__ import annotations

import math
import os
import re

from qgis.core import QgsCoordinateReferenceSystem, QgsSettings
from qgis.gui import QgsProjectionSelectionWidget
from qgis.PyQt.QtWidgets import (QComboBox, QDialog, QDialogButtonBox, QDoubleSpinBox, QFileDialog, QFormLayout,
                                 QHBoxLayout, QLineEdit, QPushButton, QWidget)

from fotogeo.options import RESAMPLINGS

#: QgsSettings key of the folder the picker's file dialogs used last
LAST_FOLDER = "fotogeo/picker/last_folder"


def start_folder(image_path: str | None) -> str:
    """The folder a file dialog opens in: the picker's last one, else the image's, else ''."""
    last = QgsSettings().value(LAST_FOLDER, "", type=str)
    if last and os.path.isdir(last):
        return last
    return os.path.dirname(image_path) if image_path else ""


def remember(path: str) -> None:
    """Remember the folder of a chosen ``path`` for the next dialog."""
    if path:
        QgsSettings().setValue(LAST_FOLDER, os.path.dirname(os.path.abspath(path)))


def suggested(image_path: str | None, suffix: str) -> str:
    """``<start folder>/<image stem><suffix>``: the file name a save dialog proposes."""
    stem = os.path.splitext(os.path.basename(image_path))[0] if image_path else "fotogeo"
    return os.path.join(start_folder(image_path), stem + suffix)


def round_size(size: float) -> float:
    """``size`` rounded to the nearest of 1, 1.5, 2, 2.5, 3, 4, 5, 6, 8 × 10^k (the pixel sizes map products use).

    >>> [round_size(v) for v in (5.7523, 0.27, 0.3333, 11.0, 0.049)]
    [6.0, 0.25, 0.3, 10.0, 0.05]
    """
    if not size or not math.isfinite(size) or size <= 0:
        return 0.0
    k = math.floor(math.log10(size))
    steps = [m * 10.0 ** e for e in (k, k + 1) for m in (1, 1.5, 2, 2.5, 3, 4, 5, 6, 8)]
    return float(f"{min(steps, key=lambda s: abs(math.log(s / size))):.6g}")


def ground_resolution(fit: dict) -> float | None:
    """The image's ground sample distance (map units per pixel) from the fit's pixel → map grid: the median over
    the grid's cells of sqrt(cell area on the ground / cell area in pixels); None without a grid."""
    g = (fit or {}).get("forward") or {}
    cols, rows, xs, ys = g.get("cols") or [], g.get("rows") or [], g.get("x"), g.get("y")
    sizes = []
    for i in range(len(rows) - 1):
        for j in range(len(cols) - 1):
            try:
                ax, ay = xs[i][j + 1] - xs[i][j], ys[i][j + 1] - ys[i][j]
                bx, by = xs[i + 1][j] - xs[i][j], ys[i + 1][j] - ys[i][j]
            except TypeError:  # a node without a value (null)
                continue
            pixels = abs((cols[j + 1] - cols[j]) * (rows[i + 1] - rows[i]))
            if pixels and math.isfinite(ax * by - ay * bx):
                sizes.append(math.sqrt(abs(ax * by - ay * bx) / pixels))
    return sorted(sizes)[len(sizes) // 2] if sizes else None


def horizontal_crs(crs: QgsCoordinateReferenceSystem) -> QgsCoordinateReferenceSystem:
    """The horizontal part of a compound CRS (a DEM's "projected + height"); any other CRS as it is."""
    wkt = crs.toWkt(QgsCoordinateReferenceSystem.WKT2_2019)
    m = re.match(r"\s*(COMPOUNDCRS|COMPD_CS)\s*\[\s*\"(?:[^\"]|\"\")*\"\s*,\s*", wkt)
    if not m:
        return crs
    depth, start = 0, m.end()
    for k in range(start, len(wkt)):  # the first member: up to its matching "]"
        depth += {"[": 1, "]": -1}.get(wkt[k], 0)
        if wkt[k] == "]" and depth == 0:
            part = QgsCoordinateReferenceSystem.fromWkt(wkt[start:k + 1])
            return part if part.isValid() else crs
    return crs


class RectifyDialog(QDialog):
    """Output file, resampling, resolution and CRS of a rectification (module docstring)."""

    def __init__(self, parent, image_path: str | None, crs: QgsCoordinateReferenceSystem,
                 resolution: float | None = None):
        super().__init__(parent)
        self.setWindowTitle("fotogeo: rectify the image")
        form = QFormLayout(self)
        self.path = QLineEdit(suggested(image_path, "_rectified.tif"))
        browse = QPushButton("…")
        browse.clicked.connect(self._browse)
        row = QWidget()
        box = QHBoxLayout(row)
        box.setContentsMargins(0, 0, 0, 0)
        box.addWidget(self.path)
        box.addWidget(browse)
        form.addRow("Output GeoTIFF", row)
        self.resampling = QComboBox()
        self.resampling.addItems(list(RESAMPLINGS))
        self.resampling.setCurrentText("cubic" if "cubic" in RESAMPLINGS else RESAMPLINGS[0])
        form.addRow("Resampling", self.resampling)
        self.resolution = QDoubleSpinBox()
        self.resolution.setRange(0.0, 1e6)
        self.resolution.setDecimals(3)
        self.resolution.setSpecialValueText("the image's ground sample distance")
        self.resolution.setValue(round_size(resolution) if resolution else 0.0)
        form.addRow("Pixel size (map units)", self.resolution)
        self.crs = QgsProjectionSelectionWidget()
        self.crs.setCrs(horizontal_crs(crs))
        units = self.crs.crs().mapUnits()  # another CRS's units: the pixel size of the old one means nothing there
        self.crs.crsChanged.connect(lambda c: c.mapUnits() != units and self.resolution.setValue(0.0))
        form.addRow("Output CRS", self.crs)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def _browse(self):
        path, _ = QFileDialog.getSaveFileName(self, "Rectified GeoTIFF", self.path.text(), "GeoTIFF (*.tif)")
        if path:
            self.path.setText(path)

    def choices(self) -> dict:
        """``{"path", "resampling", "resolution" (None: the GSD), "crs" (QgsCoordinateReferenceSystem)}``."""
        return {"path": self.path.text().strip(), "resampling": self.resampling.currentText(),
                "resolution": self.resolution.value() or None, "crs": self.crs.crs()}
