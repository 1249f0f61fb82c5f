"""Simulated mouse input for the GCP picker dock (tests/picker_gui_script.py, the desktop test's startup script).

Events are :class:`QgsMapMouseEvent` s handed to the picker's map tools, as QGIS's own GUI tests do; positions
are screen pixels of the canvas, computed from the canvas's current map-to-pixel transform.
"""
from __future__ import annotations

from qgis.core import QgsPointXY
from qgis.gui import QgsMapMouseEvent
from qgis.PyQt.QtCore import QEvent, QPoint, Qt

#: the dock's tool keys (processing_provider.picker.map_tools; the desktop imports the plugin under another name)
IMAGE, MAP = "image", "map"


def mouse(tool, kind, pos: QPoint, button=Qt.LeftButton):
    canvas = tool.canvas()
    buttons = button if kind != QEvent.MouseButtonRelease else Qt.NoButton
    event = QgsMapMouseEvent(canvas, kind, pos, button, buttons, Qt.NoModifier)
    {QEvent.MouseButtonPress: tool.canvasPressEvent, QEvent.MouseMove: tool.canvasMoveEvent,
     QEvent.MouseButtonRelease: tool.canvasReleaseEvent}[kind](event)


def click(tool, pos: QPoint, button=Qt.LeftButton):
    mouse(tool, QEvent.MouseMove, pos, Qt.NoButton)
    mouse(tool, QEvent.MouseButtonPress, pos, button)
    mouse(tool, QEvent.MouseButtonRelease, pos, button)


def drag(tool, start: QPoint, end: QPoint):
    mouse(tool, QEvent.MouseButtonPress, start)
    mouse(tool, QEvent.MouseMove, QPoint((start.x() + end.x()) // 2, (start.y() + end.y()) // 2))
    mouse(tool, QEvent.MouseMove, end)
    mouse(tool, QEvent.MouseButtonRelease, end)


def screen(canvas, x, y) -> QPoint:
    p = canvas.getCoordinateTransform().transform(QgsPointXY(x, y))
    return QPoint(round(p.x()), round(p.y()))


def gcps(dock):
    return [{"id": g.id, "col": g.col, "row": g.row, "x": g.x, "y": g.y, "z": g.z, "role": g.role, "enabled": g.enabled}
            for g in dock.controller.store.gcps()]


def table(dock):
    return [{k: v for k, v in dock.table.row_values(i).items()} for i in range(dock.table.rowCount())]


def map_screen(dock, x, y) -> QPoint:
    """Screen position on the main canvas of map point (x, y) in the GCP layer's CRS."""
    p = dock.controller.layer_to_map(x, y)
    return screen(dock.map_canvas, p.x(), p.y())


def pick(dock, truth, image_first=True):
    """One GCP by two clicks (image then map, or map then image) at the truth's screen positions."""
    img = screen(dock.image_canvas, truth["col"], -truth["row"])
    mp = map_screen(dock, truth["x"], truth["y"])
    for side in ((IMAGE, MAP) if image_first else (MAP, IMAGE)):
        click(dock.tools[side], img if side == IMAGE else mp)
