"""The QGIS plugin object: registers the fotogeo Processing provider; in the desktop, one menu.

``initProcessing`` is what QGIS calls for Processing-only use (qgis_process, headless) and
stays free of GUI code; ``initGui`` calls it and adds the menu *fotogeo* with *Install /
repair runtime* (:mod:`processing_provider.install_action`) and *GCP picker* (menu and toolbar),
which opens the dock :class:`processing_provider.picker.dock.PickerDock`. Every other capability is
in the toolbox. ``unload`` closes the dock and the picker's worker session.
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
        self.picker_action = None
        self.picker = None

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
            from qgis.PyQt.QtGui import QIcon
            from qgis.PyQt.QtWidgets import QAction
            from .install_action import MENU
            icon = QIcon(os.path.join(os.path.dirname(os.path.abspath(__file__)), "icon.svg"))
            self.picker_action = QAction(icon, "GCP picker", self.iface.mainWindow())
            self.picker_action.setObjectName("fotogeoGcpPicker")
            self.picker_action.triggered.connect(self.open_picker)
            self.iface.addPluginToMenu(MENU, self.picker_action)
            self.iface.addToolBarIcon(self.picker_action)

    def open_picker(self):
        """Show the GCP picker dock (created at the first call) on the right of the main window: as a tab beside
        a dock already there (the Processing toolbox), so that it gets the area's full height, not half of it."""
        if self.picker is None:
            from qgis.PyQt.QtCore import Qt, QTimer
            from qgis.PyQt.QtWidgets import QDockWidget
            from .picker.dock import PickerDock
            window = self.iface.mainWindow()
            self.picker = PickerDock(self.iface.mapCanvas(), window, message_bar=self.iface.messageBar())
            right = [d for d in window.findChildren(QDockWidget) if d.isVisible() and not d.isFloating()
                     and window.dockWidgetArea(d) == Qt.DockWidgetArea.RightDockWidgetArea]
            self.iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.picker)
            if right:  # the tallest: the toolbox rather than a viewer below it
                window.tabifyDockWidget(max(right, key=lambda d: d.height()), self.picker)
            # a dock below it (the Results Viewer) keeps what it needs, the picker gets the rest of the height
            QTimer.singleShot(0, lambda: window.resizeDocks([self.picker], [window.height()], Qt.Orientation.Vertical))
        self.picker.show()
        self.picker.raise_()
        return self.picker

    def unload(self):
        if self.picker is not None:
            self.picker.close_picker()
            self.iface.removeDockWidget(self.picker)
            self.picker.deleteLater()
            self.picker = None
        if self.picker_action is not None:
            from .install_action import MENU
            self.iface.removePluginMenu(MENU, self.picker_action)
            self.iface.removeToolBarIcon(self.picker_action)
            self.picker_action = None
        from .session import close_shared_session
        close_shared_session()
        preview = sys.modules.get(f"{__package__}.picker.preview")  # loaded only once a picker was opened
        if preview is not None:
            preview.remove_folders()
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
