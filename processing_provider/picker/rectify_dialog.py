"""The picker's Rectify options and the folder its file dialogs open in.

*Rectify…* asks what the Georeferencer's transformation settings ask: the output file, the
resampling, the pixel size (0: the image's ground sample distance) and the output CRS (default: the
GCP layer's; another one gets the GCPs transformed into it before the fit, so the image is resampled
once, straight onto the chosen grid). File dialogs start in the folder last used by the picker, else
beside the image — not in the home folder.
"""
from __future__ import annotations

import os

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


class RectifyDialog(QDialog):
    """Output file, resampling, resolution and CRS of a rectification (module docstring)."""

    def __init__(self, parent, image_path: str | None, crs: QgsCoordinateReferenceSystem):
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
        form.addRow("Pixel size (map units)", self.resolution)
        self.crs = QgsProjectionSelectionWidget()
        self.crs.setCrs(crs)
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
