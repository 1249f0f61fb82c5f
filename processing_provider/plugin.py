"""The QGIS plugin object: registers the fotogeo Processing provider; in the desktop, one menu.

``initProcessing`` is what QGIS calls for Processing-only use (qgis_process, headless) and
stays free of GUI code; ``initGui`` calls it and adds the menu *fotogeo* with *Install /
repair runtime* (:mod:`processing_provider.install_action`). Every capability is in the toolbox.
"""
from __future__ import annotations

import os
import sys

from qgis.core import QgsApplication

from .provider import FotogeoProvider


class FotogeoPlugin:
    def __init__(self, iface=None):
        self.iface = iface
        self.provider = None
        self.menu = None

    def initProcessing(self):
        if self.provider is None:
            provider = FotogeoProvider()
            if QgsApplication.processingRegistry().addProvider(provider):
                self.provider = provider

    def initGui(self):
        self.initProcessing()
        if self.iface is not None:
            from .install_action import RuntimeMenu
            self.menu = RuntimeMenu(self.iface, self.provider)

    def unload(self):
        if self.menu is not None:
            self.menu.remove()
            self.menu = None
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
        _forget_vendored_fotogeo()


def _forget_vendored_fotogeo():
    """Drop the plugin's own copy of fotogeo from ``sys.modules`` so a reload imports the new one.

    In the built plugin fotogeo sits beside ``processing_provider`` (see scripts/build_plugin.py);
    QGIS's unloader only removes the plugin package's own modules.
    """
    vendored = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "fotogeo") + os.sep
    for name, module in list(sys.modules.items()):
        if name == "fotogeo" or name.startswith("fotogeo."):
            if (getattr(module, "__file__", None) or "").startswith(vendored):
                del sys.modules[name]


def classFactory(iface):  # noqa: N802 - the name QGIS looks for
    return FotogeoPlugin(iface)
