"""The picker's live preview driven by simulated clicks in a GUI QgsApplication (offscreen); run by
tests/test_qgis_picker_preview.py as ``python picker_preview_script.py ARGS.json``.

Affine model: two GCPs (no preview), the third (the preview appears), GCP 3 dragged on the map (the preview
is redrawn: its pictures before and after are saved as PNG for the test to compare), the preview switched
off and on, a GCP deleted below the minimum (the preview goes). Writes ``ARGS["out"]/state.json``.
"""
from __future__ import annotations

import os
import time

import picker_gui_script as base  # noqa: E402 - its QgsApplication, setup and pump
from picker_driver import drag, frame_dock, map_screen, pick, run  # noqa: E402
from picker_driver import settle as settle_fit  # noqa: E402
from qgis.PyQt.QtCore import QPoint  # noqa: E402

ARGS, STATE, pump = base.ARGS, base.STATE, base.pump


def settled(dock, seconds=60.0) -> dict:
    """Pump events until the fit, then the preview, has answered the newest request; what it showed."""
    settle_fit(dock)
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        pump(0.05)
        p = dock.preview
        if not p.running and p.pending is None and p.last.get("generation") == p.generation:
            break
    item = dock.preview.item
    shown = {k: v for k, v in dock.preview.last.items() if k != "output"}
    shown["drawn"] = item.image is not None and item.isVisible()
    return shown


def save(dock, name) -> dict:
    item = dock.preview.item
    path = os.path.join(ARGS["out"], name)
    item.image.save(path, "PNG")
    e = item.extent
    return {"png": path, "extent": [e.xMinimum(), e.yMinimum(), e.xMaximum(), e.yMaximum()]}


def main():
    canvas, dock = frame_dock(base.setup, ARGS, "affine")
    truth = ARGS["gcps"]
    STATE["canvas"] = [canvas.width(), canvas.height()]
    for k in range(2):
        pick(dock, truth[k])
    STATE["two"] = settled(dock)
    pick(dock, truth[2])
    STATE["three"] = {**settled(dock), **save(dock, "before.png")}
    g3 = dock.controller.gcp("3")
    start = map_screen(dock, g3.x, g3.y)
    STATE["gcp3_screen"] = [start.x(), start.y()]
    STATE["drag"] = [25, -15]
    drag(dock.tools[base.MAP], start, start + QPoint(*STATE["drag"]))
    STATE["dragged"] = {**settled(dock), **save(dock, "after.png")}
    dock.preview_check.setChecked(False)
    STATE["off"] = settled(dock)
    dock.preview_check.setChecked(True)
    STATE["on_again"] = settled(dock)
    dock.controller.delete("1")
    STATE["below_minimum"] = settled(dock)
    dock.close_picker()
    STATE["foreign_layer"] = foreign_layer()
    STATE["closed"] = {"folder_removed": not os.path.exists(dock.preview.folder),
                       "item_in_scene": dock.preview.item.scene() is not None}


def foreign_layer():
    """A point layer with only col and row (as points-to-layer may give): disabling a point adds the field."""
    from processing_provider.picker.gcp_layer import Gcp, GcpLayer
    from qgis.core import QgsField, QgsVectorLayer
    from qgis.PyQt.QtCore import QVariant
    layer = QgsVectorLayer("Point", "foreign", "memory")
    layer.dataProvider().addAttributes([QgsField("col", QVariant.Double), QgsField("row", QVariant.Double)])
    layer.updateFields()
    store = GcpLayer(layer)
    on = store.add(Gcp("1", 1.0, 2.0, 10.0, 20.0))
    off = store.add(Gcp("2", 3.0, 4.0, 30.0, 40.0, enabled=False))
    fields_after_add = layer.fields().names()
    from dataclasses import replace
    store.update(replace(on, enabled=False))
    return {"fields": fields_after_add, "enabled": [g.enabled for g in store.gcps()], "off_fid": off.fid >= 0}


if __name__ == "__main__":
    run(main, STATE, ARGS["out"])
