"""The fotogeo Processing provider: a plain list of algorithms, no GUI code."""
from __future__ import annotations

import os

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from .algorithms import ALGORITHMS
from . import runner
from .side_files import guard_qgis_process

PROVIDER_ID = "fotogeo"
ICON = os.path.join(os.path.dirname(os.path.abspath(__file__)), "icon.svg")


def _version() -> str:
    try:  # the fotogeo package is pure Python: importing its __init__ needs no third-party package
        import fotogeo
        return fotogeo.__version__
    except Exception:  # noqa: BLE001
        return ""


class FotogeoProvider(QgsProcessingProvider):
    def id(self):
        return PROVIDER_ID

    def name(self):
        return "fotogeo"

    def longName(self):
        v = _version()
        return f"fotogeo {v} — image registration, orientation and matching" if v else "fotogeo"

    def versionInfo(self):
        return _version()

    def icon(self):
        return QIcon(ICON) if os.path.exists(ICON) else QgsApplication.getThemeIcon("/processingAlgorithm.svg")

    def svgIconPath(self):
        return ICON

    def loadAlgorithms(self):
        guard_qgis_process()  # qgis_process loads raster inputs as layers before an algorithm runs
        for cls in ALGORITHMS:
            self.addAlgorithm(cls())
        ok, why = runner.runtime_status(refresh=True)
        QgsMessageLog.logMessage(why, "fotogeo", Qgis.Info if ok else Qgis.Warning)
