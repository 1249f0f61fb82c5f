"""The fotogeo Processing provider: a plain list of algorithms, no GUI code."""
from __future__ import annotations

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsProcessingProvider

from .algorithms import ALGORITHMS
from .algorithms.base import dependency_message, missing_dependencies

PROVIDER_ID = "fotogeo"


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
        return QgsApplication.getThemeIcon("/processingAlgorithm.svg")

    def loadAlgorithms(self):
        for cls in ALGORITHMS:
            self.addAlgorithm(cls())
        missing = missing_dependencies(import_them=False)
        if missing:
            QgsMessageLog.logMessage(dependency_message(missing), "fotogeo", Qgis.Warning)
