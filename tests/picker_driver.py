"""Simulated mouse input for the GCP picker dock (tests/picker_gui_script.py, the desktop test's startup script).

Events are :class:`QgsMapMouseEvent` s handed to the picker's map tools, as QGIS's own GUI tests do; positions
are screen pixels of the canvas, computed from the canvas's current map-to-pixel transform.

:func:`frame_dock` and :func:`run` are the headless scripts' common start and end.

The dock refits off the GUI thread: :func:`settle` runs the event loop until the newest fit has arrived;
:func:`click`, :func:`drag`, :func:`pick`, :func:`gcps`, :func:`table` and :func:`fitted` settle first or after.
"""
from __future__ import annotations

import json
import os
import sys
import time
import traceback

from qgis.core import QgsCoordinateReferenceSystem, QgsPointXY, QgsRectangle
from qgis.gui import QgsMapMouseEvent
from qgis.PyQt.QtCore import QCoreApplication, QEvent, QPoint, Qt
from qgis.PyQt.QtTest import QTest

#: the dock's tool keys (processing_provider.picker.map_tools; the desktop imports the plugin under another name)
IMAGE, MAP = "image", "map"


def wait_for_fit(controller, seconds: float = 120.0):
    """Run the event loop until ``controller`` has applied its newest fit (a bound for a stuck worker only)."""
    end = time.monotonic() + seconds
    while controller.busy and time.monotonic() < end:
        QCoreApplication.processEvents()
        time.sleep(0.005)
    QCoreApplication.processEvents()


def settle(dock):
    """The dock's newest fit applied (table, summary and marks updated)."""
    wait_for_fit(dock.controller)


def fitted(dock) -> dict:
    """The dock's fit of the current GCPs and settings."""
    settle(dock)
    return dock.controller.fit


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
    wait_for_fit(tool.controller)


def drag(tool, start: QPoint, end: QPoint):
    mouse(tool, QEvent.MouseButtonPress, start)
    mouse(tool, QEvent.MouseMove, QPoint((start.x() + end.x()) // 2, (start.y() + end.y()) // 2))
    mouse(tool, QEvent.MouseMove, end)
    mouse(tool, QEvent.MouseButtonRelease, end)
    wait_for_fit(tool.controller)


def click_header(t, name: str) -> int:
    """A mouse click on the table ``t``'s header of column ``name``; its column number."""
    header = t.horizontalHeader()
    j = next(k for k in range(header.count()) if t.horizontalHeaderItem(k).text() == name)
    t.scrollToItem(t.item(0, j))
    QTest.mouseClick(header.viewport(), Qt.LeftButton, Qt.NoModifier,
                     QPoint(header.sectionViewportPosition(j) + header.sectionSize(j) // 2, header.height() // 2))
    QCoreApplication.processEvents()
    return j


def sort_by(t, name: str, order) -> int:
    """Clicks on the header of ``name`` until the table is sorted in ``order``; the number of clicks (1 or 2)."""
    for clicks in (1, 2):
        j = click_header(t, name)
        header = t.horizontalHeader()
        if header.sortIndicatorSection() == j and header.sortIndicatorOrder() == order:
            return clicks
    raise AssertionError(f"two clicks on {name} did not sort it {order}")


def screen(canvas, x, y) -> QPoint:
    p = canvas.getCoordinateTransform().transform(QgsPointXY(x, y))
    return QPoint(round(p.x()), round(p.y()))


def gcps(dock):
    settle(dock)
    return [{"id": g.id, "col": g.col, "row": g.row, "x": g.x, "y": g.y, "z": g.z, "role": g.role, "enabled": g.enabled}
            for g in dock.controller.store.gcps()]


def table(dock):
    settle(dock)
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


def frame_dock(setup, args: dict, model: str):
    """``setup()``'s canvas and dock with ``args["frame"]`` open, a new GCP layer in ``args["crs"]``, ``model``
    chosen and the map canvas over the GCPs ``args["gcps"]``."""
    canvas, dock = setup()
    assert dock.open_image(args["frame"]), dock.last_message
    dock.new_gcp_layer(QgsCoordinateReferenceSystem.fromWkt(args["crs"]))
    dock.model_combo.setCurrentText(model)
    xs, ys = [g["x"] for g in args["gcps"]], [g["y"] for g in args["gcps"]]
    canvas.setExtent(QgsRectangle(min(xs) - 50, min(ys) - 50, max(xs) + 50, max(ys) + 50))
    canvas.refresh()
    end = time.monotonic() + 0.3
    while time.monotonic() < end:
        QCoreApplication.processEvents()
        time.sleep(0.01)
    return canvas, dock


def run(main, state: dict, out: str):
    """``main()``, then ``state`` (its traceback as ``error`` if it raised) written to ``out/state.json``; exits at
    once (one QgsApplication per process, no teardown), the live preview's folders removed first as the
    interpreter's exit would (:func:`processing_provider.picker.preview.remove_folders`)."""
    try:
        main()
    except Exception:
        state["error"] = traceback.format_exc()
    with open(os.path.join(out, "state.json"), "w") as f:
        json.dump({k: v for k, v in state.items() if not k.startswith("_")}, f)
    sys.stdout.flush()
    for name, module in list(sys.modules.items()):  # os._exit skips the interpreter's exit, whose clean-up this is
        if name.endswith("picker.preview"):
            module.remove_folders()
    os._exit(0)
