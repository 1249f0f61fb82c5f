"""The GCP picker driven by simulated mouse events in a GUI QgsApplication (offscreen); run by
tests/test_qgis_picker.py as ``python picker_gui_script.py ARGS.json`` (one QgsApplication per process).

Writes what it saw to ``ARGS["out"]/state.json``: the stored GCPs after each step, the fits, the
table's rows, the messages shown. The test process compares them with ``fotogeo orient``.
"""
from __future__ import annotations

import json
import os
import sys
import time

ARGS = json.loads(open(sys.argv[1]).read())
sys.path.insert(0, ARGS["root"])
sys.path.insert(0, os.path.join(ARGS["root"], "tests"))
from qgis.core import (QgsApplication, QgsCoordinateReferenceSystem, QgsFeature, QgsGeometry,  # noqa: E402
                       QgsPointXY, QgsProject, QgsRasterLayer, QgsRectangle, QgsSnappingConfig, QgsTolerance,
                       QgsVectorLayer)

APP = QgsApplication([], True)
APP.initQgis()
from qgis.gui import QgsMapCanvas, QgsMapCanvasSnappingUtils  # noqa: E402
from qgis.PyQt.QtCore import QEvent, QPoint, Qt  # noqa: E402

from picker_driver import click, drag, fitted, gcps, map_screen, mouse, pick, run, screen, settle, table  # noqa: E402
from processing_provider.picker.dock import PickerDock  # noqa: E402
from processing_provider.picker.map_tools import IMAGE, MAP  # noqa: E402
from processing_provider.picker.table import COLUMNS  # noqa: E402
from processing_provider.session import WorkerSession  # noqa: E402

STATE: dict = {}


def pump(seconds=0.05):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        APP.processEvents()
        time.sleep(0.01)


def setup():
    crs = QgsCoordinateReferenceSystem.fromWkt(ARGS["crs"])
    QgsProject.instance().setCrs(crs)
    canvas = QgsMapCanvas()
    canvas.resize(800, 800)
    canvas.setDestinationCrs(crs)
    canvas.show()
    utils = QgsMapCanvasSnappingUtils(canvas, canvas)  # owned by the canvas (the app keeps its own)
    canvas.setSnappingUtils(utils)
    STATE["_utils"] = utils
    dock = PickerDock(canvas, session=WorkerSession())
    dock.resize(900, 1000)
    dock.show()
    pump(0.3)
    return canvas, dock


def snapping_layer(canvas, vertex):
    """A line layer with a vertex at ``vertex`` on ``canvas``; project snapping on vertices, 12 px, handed to
    the canvas's snapping utils as QGIS's main window does when the project's snapping settings change."""
    crs = canvas.mapSettings().destinationCrs()
    layer = QgsVectorLayer("LineString", "roads", "memory")
    layer.setCrs(crs)
    f = QgsFeature()
    f.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(vertex[0] - 50, vertex[1] - 40), QgsPointXY(*vertex),
                                              QgsPointXY(vertex[0] + 60, vertex[1] - 30)]))
    layer.dataProvider().addFeatures([f])
    QgsProject.instance().addMapLayer(layer)
    config = QgsSnappingConfig(QgsProject.instance())
    config.setEnabled(True)
    config.setMode(QgsSnappingConfig.AllLayers)
    config.setTypeFlag(QgsSnappingConfig.VertexFlag)
    config.setTolerance(12)
    config.setUnits(QgsTolerance.Pixels)
    QgsProject.instance().setSnappingConfig(config)
    canvas.setLayers([layer])
    STATE["_utils"].setConfig(QgsProject.instance().snappingConfig())
    return layer


def main():
    canvas, dock = setup()
    STATE["not_raster"] = [dock.open_image(ARGS["not_raster"]), dock.last_message]
    dock.last_message = ""
    for k in range(len(ARGS["frame"]) - 4, len(ARGS["frame"])):  # typing the last characters: "….ti", "….tif"
        dock.image_file.setFilePath(ARGS["frame"][:k])
    typing = [dock.last_message, dock.image is not None]
    dock.image_file.lineEdit().editingFinished.emit()  # typing ended on an unfinished name
    STATE["typing"] = typing + [dock.last_message]
    assert dock.open_image(ARGS["frame"]), dock.last_message
    sample_image(dock)
    store = dock.new_gcp_layer(QgsCoordinateReferenceSystem.fromWkt(ARGS["crs"]))
    dock.controller.place("image", QgsPointXY(100.5, -200.5))  # a first click: the status says what comes next
    STATE["first_click"] = dock.last_message
    dock.controller.pending = None
    dock.controller.show()
    dock.model_combo.setCurrentText("dlt")
    dock.height_combo.setCurrentText("dem")
    dem, small_dem = QgsRasterLayer(ARGS["dem"], "dem"), QgsRasterLayer(ARGS["small_dem"], "small dem")
    QgsProject.instance().addMapLayers([dem, small_dem], False)
    dock.dem_combo.setLayer(dem)
    truth = ARGS["gcps"]
    xs, ys = [g["x"] for g in truth], [g["y"] for g in truth]
    canvas.setExtent(QgsRectangle(min(xs) - 50, min(ys) - 50, max(xs) + 50, max(ys) + 50))
    canvas.refresh()
    pump(0.3)
    STATE["map_units_per_pixel"] = canvas.mapUnitsPerPixel()
    STATE["image_units_per_pixel"] = dock.image_canvas.mapUnitsPerPixel()
    picking(canvas, dock, truth)
    editing(dock)
    delete_key(dock)
    files(dock, store)
    heights_and_models(dock, dem, small_dem)
    other_project_crs(canvas, dock, store, truth)
    plain = QgsVectorLayer("Point", "plain points", "memory")  # a point layer without the GCP fields
    QgsProject.instance().addMapLayer(plain)
    dock.gcp_combo.setLayer(plain)
    STATE["plain_layer"] = {"message": dock.last_message, "store": dock.controller.store is not None}
    dock.gcp_combo.setLayer(store.layer)
    gpkg = dock.new_gcp_layer(QgsCoordinateReferenceSystem.fromWkt(ARGS["crs"]),
                              path=os.path.join(ARGS["out"], "new_gcps.gpkg"))
    for k in (14, 15, 16):
        pick(dock, truth[k])
    STATE["gpkg_layer"] = {"gcps": gcps(dock), "provider": gpkg.layer.providerType()}
    dock.gcp_combo.setLayer(store.layer)
    large_image(dock)


def sample_image(dock):
    """Values the image canvas's layer shows at (col + 0.5, -(row + 0.5)) and GDAL's at (col, row) / mirrored."""
    provider = dock.image.layer.dataProvider()
    from osgeo import gdal  # QGIS's own GDAL: the same JPEG decoder as the layer
    source = gdal.Open(ARGS["frame"])
    band = source.GetRasterBand(1)  # (its ReadAsArray needs the system numpy: single-pixel reads)
    value = lambda c, r: band.ReadRaster(c, r, 1, 1, buf_type=gdal.GDT_Byte)[0]  # noqa: E731
    STATE["image_extent"] = dock.image.layer.extent().toString(3)
    STATE["samples"] = [[c, r, provider.sample(QgsPointXY(c + 0.5, -(r + 0.5)), 1)[0], value(c, r),
                         value(c, band.YSize - 1 - r)]
                        for c, r in ((0, 0), (639, 0), (0, 1151), (300, 700), (17, 1003), (250, 10), (400, 90))]


def picking(canvas, dock, truth):
    """Ten GCPs by clicks (the first snapped onto a road vertex 4.6 screen px away); the prediction."""
    mupp = canvas.mapUnitsPerPixel()
    vertex = (truth[0]["x"] + 4.3 * mupp, truth[0]["y"] - 1.7 * mupp)
    snapping_layer(canvas, vertex)
    canvas.refresh()
    mouse(dock.tools[MAP], QEvent.MouseMove, map_screen(dock, *vertex), Qt.NoButton)  # builds the snapping index
    pump(1.0)
    mouse(dock.tools[MAP], QEvent.MouseMove, map_screen(dock, truth[0]["x"], truth[0]["y"]), Qt.NoButton)
    match = dock.tools[MAP].snap_indicator.match()  # QGIS's snap indicator shows the vertex under the cursor
    STATE["indicator"] = [match.isValid(), match.point().x(), match.point().y()]
    STATE["vertex"] = vertex
    for k in range(3):
        pick(dock, truth[k], image_first=k % 2 == 0)
    STATE["few"] = {"summary": dock.summary.text(), "fit": fitted(dock), "gcps": gcps(dock)}
    for k in range(3, 10):
        pick(dock, truth[k], image_first=k % 2 == 0)
    STATE["picked"] = {"gcps": gcps(dock), "fit": fitted(dock), "table": table(dock),
                       "summary": dock.summary.text()}
    dock.controller.store.export_gpkg(os.path.join(ARGS["out"], "picked.gpkg"))
    STATE["refit"] = refit_off_the_gui_thread(dock)
    # the cursor over GCP 2's image position: the map canvas shows where the model puts it
    g2 = dock.controller.gcp("2")
    mouse(dock.tools[IMAGE], QEvent.MouseMove, screen(dock.image_canvas, g2.col, -g2.row), Qt.NoButton)
    pred = dock.controller.overlays[MAP].state.predicted
    STATE["predicted"] = [pred.x(), pred.y()] if pred is not None else None


def refit_off_the_gui_thread(dock):
    """One refit whose worker call is held until a 0 ms QTimer has fired in the GUI thread. The timer fires only if
    refit() returned and the event loop runs while the fit is under way; a fit made in the GUI thread would
    block the loop in the held call (until the hold's 60 s bound: ``released`` False)."""
    import threading
    from qgis.PyQt.QtCore import QTimer
    controller, gate, seen, fits = dock.controller, threading.Event(), {}, []
    session = controller.session
    real_call = session.call

    def held_call(tool, **kwargs):
        seen.update(thread=threading.get_ident(), released=gate.wait(60))
        return real_call(tool, **kwargs)

    def on_fit(fit):
        fits.append(fit)
    session.call = held_call
    controller.fitted.connect(on_fit)
    try:
        controller.refit()
        returned = {"busy": controller.busy, "fits": len(fits)}
        QTimer.singleShot(0, lambda: (seen.update(timer_fits=len(fits)), gate.set()))
        settle(dock)
    finally:
        session.call = real_call
        controller.fitted.disconnect(on_fit)
    return {"returned": returned, "timer_fits": seen.get("timer_fits"), "released": seen.get("released"),
            "gui_thread": seen.get("thread") == threading.get_ident(), "fits": len(fits),
            "ok": bool(fits) and fits[-1].get("ok")}


def editing(dock):
    """Drag on both canvases, right-click delete, undo/redo, a role change in the table."""
    g4 = dock.controller.gcp("4")
    start = screen(dock.image_canvas, g4.col, -g4.row)
    drag(dock.tools[IMAGE], start, start + QPoint(8, 5))
    STATE["moved"] = {"before": [g4.col, g4.row], "after": [dock.controller.gcp("4").col, dock.controller.gcp("4").row]}
    g6 = dock.controller.gcp("6")
    start = map_screen(dock, g6.x, g6.y)
    drag(dock.tools[MAP], start, start + QPoint(-6, 3))
    STATE["moved_map"] = {"before": [g6.x, g6.y], "after": [dock.controller.gcp("6").x, dock.controller.gcp("6").y]}
    g5 = dock.controller.gcp("5")
    before_delete = gcps(dock)
    click(dock.tools[MAP], map_screen(dock, g5.x, g5.y), Qt.RightButton)
    after_delete = gcps(dock)
    stack = dock.controller.undo_stack
    stack.undo()
    after_undo = gcps(dock)
    stack.redo()
    after_redo = gcps(dock)
    stack.undo()
    STATE["delete"] = {"before": before_delete, "deleted": after_delete, "undone": after_undo, "redone": after_redo,
                       "undone_again": gcps(dock), "undo_text": stack.undoText()}
    stack.undo()  # and both moves: back to the clicked points
    stack.undo()
    STATE["after_undo_moves"] = {"gcps": gcps(dock), "fit": fitted(dock), "table": table(dock)}
    dock.table.item(1, COLUMNS.index("role")).setText("check")  # GCP 2: a check point (the role column)
    STATE["role"] = {"gcps": gcps(dock), "fit": fitted(dock)}
    dock.controller.store.export_gpkg(os.path.join(ARGS["out"], "with_check.gpkg"))
    dock.table.item(2, COLUMNS.index("on")).setCheckState(Qt.Unchecked)  # GCP 3 disabled: ignored
    STATE["disabled"] = {"gcps": gcps(dock), "fit": fitted(dock), "table": table(dock)}
    dock.controller.store.export_gpkg(os.path.join(ARGS["out"], "with_disabled.gpkg"))
    dock.controller.undo_stack.undo()
    STATE["enabled_again"] = gcps(dock)


def delete_key(dock):
    """The Delete key on the table: nothing selected, then the last two rows selected (undo adds the GCPs back
    at the end of the layer, so the layer's order, which the exports below keep, stays); undo, redo, undo."""
    from qgis.PyQt.QtCore import QItemSelectionModel
    from qgis.PyQt.QtGui import QKeyEvent
    pump(0.3)
    t, stack = dock.table, dock.controller.undo_stack

    def press_delete():
        APP.sendEvent(t, QKeyEvent(QEvent.KeyPress, Qt.Key_Delete, Qt.NoModifier))
        pump(0.3)
        return gcps(dock)

    before, index = gcps(dock), stack.index()
    t.clearSelection()
    unselected = press_delete()
    last_two = [g["id"] for g in before[-2:]]
    for r in [r for r in range(t.rowCount()) if t.item(r, 0).text() in last_two]:
        t.selectionModel().select(t.model().index(r, 0), QItemSelectionModel.Select | QItemSelectionModel.Rows)
    selected = t.selected_ids()
    deleted = press_delete()
    steps = stack.index() - index
    text = stack.undoText()
    stack.undo()
    undone = gcps(dock)
    stack.redo()
    redone = gcps(dock)
    stack.undo()
    end = time.monotonic() + 60  # the table fills from the refit, which may not have started yet: wait for it
    while time.monotonic() < end and t.rowCount() != len(gcps(dock)):
        settle(dock)
        pump(0.05)
    STATE["delete_key"] = {"before": before, "unselected": unselected, "last_two": last_two, "selected": selected, "deleted": deleted,
                           "steps": steps, "undo_text": text, "undone": undone, "redone": redone,
                           "table_ids": [t.item(r, 0).text() for r in range(t.rowCount())]}


def files(dock, store):
    """.points and ODM gcp_list.txt: export, then import into a new layer."""
    for key, name in (("points", "picked.points"), ("odm", "gcp_list.txt")):
        path = os.path.join(ARGS["out"], name)
        dock.gcp_combo.setLayer(store.layer)
        STATE[f"export_{key}"] = dock.export_file(path)
        dock.new_gcp_layer(QgsCoordinateReferenceSystem.fromWkt(ARGS["crs"]))
        STATE[f"import_{key}"] = dock.import_file(path)
        STATE[f"reimported_{key}"] = gcps(dock)
    dock.gcp_combo.setLayer(store.layer)


def heights_and_models(dock, dem, small_dem):
    """A constant height (DLT then projective), collinearity with the camera, a DEM missing some GCPs."""
    dock.height_combo.setCurrentText("constant")
    dock.height_spin.setValue(300.0)
    STATE["constant_dlt"] = fitted(dock)  # one height for all: coplanar points, DLT cannot be fitted
    dock.model_combo.setCurrentText("projective")
    STATE["constant"] = fitted(dock)
    dock.height_combo.setCurrentText("field")
    dock.table.item(0, COLUMNS.index("z")).setText("123.5")  # z of GCP 1 typed into the table
    z_typed, row = dock.controller.gcp("1").z, fitted(dock)["points"][0]
    dock.controller.undo_stack.undo()
    STATE["typed_height"] = {"typed": z_typed, "row": row, "undone": dock.controller.gcp("1").z,
                             "row_undone": fitted(dock)["points"][0]}
    dock.height_combo.setCurrentText("dem")
    dock.camera_file.setFilePath(ARGS["camera"])
    dock.model_combo.setCurrentText("collinearity")
    STATE["collinearity"] = {"fit": fitted(dock), "summary": dock.summary.text()}
    dock.model_combo.setCurrentText("dlt")
    dock.dem_combo.setLayer(small_dem)
    STATE["small_dem"] = {"fit": fitted(dock), "table": table(dock), "summary": dock.summary.text()}
    dock.dem_combo.setLayer(dem)


def other_project_crs(canvas, dock, store, truth):
    """The project (canvas) CRS WGS 84 lon/lat, the GCP layer's metric: one more GCP by clicks."""
    wgs84 = QgsCoordinateReferenceSystem("EPSG:4326")
    canvas.setDestinationCrs(wgs84)
    QgsProject.instance().setCrs(wgs84)
    xs, ys = [g["x"] for g in truth], [g["y"] for g in truth]
    corner = dock.controller.layer_to_map(min(xs) - 50, min(ys) - 50)
    far = dock.controller.layer_to_map(max(xs) + 50, max(ys) + 50)
    canvas.setExtent(QgsRectangle(corner.x(), corner.y(), far.x(), far.y()))
    canvas.refresh()
    pump(0.3)
    pick(dock, truth[12])
    STATE["wgs84"] = {"gcp": gcps(dock)[-1], "canvas_crs": canvas.mapSettings().destinationCrs().authid(),
                      "layer_crs_wkt": store.crs.toWkt(), "map_units_per_pixel": canvas.mapUnitsPerPixel()}


def large_image(dock):
    """A 3-band image above the pyramid threshold (lowered for the test): it shows at once, pyramids follow."""
    from processing_provider.picker import image_source
    image_source.OVERVIEW_PIXELS = 1000 * 1000
    start, frame_folder = time.monotonic(), dock.image.folder
    opened = dock.open_image(ARGS["large"])
    STATE["frame_vrt_removed"] = not os.path.exists(frame_folder)
    STATE["large"] = {"opened": opened, "open_s": time.monotonic() - start, "bands": dock.image.layer.bandCount(),
                      "task": dock.image.task is not None}
    while dock.image.task is not None and not os.path.exists(dock.image.vrt + ".ovr") and time.monotonic() - start < 60:
        pump(0.2)
    pump(0.5)
    from osgeo import gdal
    vrt = gdal.Open(dock.image.vrt)
    STATE["large"].update(overviews=vrt.GetRasterBand(1).GetOverviewCount(), vrt=dock.image.vrt,
                          message=dock.last_message, built_s=time.monotonic() - start)


def propose():
    """Proposals on the frame against the reference orthophoto, all accepted (every third a check point)."""
    canvas, dock = setup()
    assert dock.open_image(ARGS["frame"]), dock.last_message
    dock.new_gcp_layer(QgsCoordinateReferenceSystem.fromWkt(ARGS["crs"]))
    dem = QgsRasterLayer(ARGS["dem"], "dem")
    QgsProject.instance().addMapLayer(dem, False)
    dock.dem_combo.setLayer(dem)
    dock.height_combo.setCurrentText("dem")
    dock.model_combo.setCurrentText("dlt")
    # a first run cancelled after 1 s (the task manager's cancel): no proposals, the dock usable again
    task = dock.propose(reference=ARGS["reference"], count=30)
    pump(1.0)
    task.cancel()
    start = time.monotonic()
    while not dock.propose_button.isEnabled() and time.monotonic() - start < 120:
        pump(0.2)
    STATE["cancel"] = {"s": time.monotonic() - start, "error": task.error, "proposals": len(dock.controller.proposals),
                       "message": dock.last_message}
    start = time.monotonic()
    task = dock.propose(reference=ARGS["reference"], count=30)
    while not dock.propose_button.isEnabled() and time.monotonic() - start < 600:
        pump(0.2)
    STATE["propose_s"] = time.monotonic() - start
    STATE["task_error"] = task.error
    STATE["proposals"] = list(dock.controller.proposals)
    # one accepted by a click on its square on the image, the next rejected by a right click on the map
    first, second = dock.controller.proposals[:2]
    click(dock.tools[IMAGE], screen(dock.image_canvas, first["col"], -first["row"]))
    xs, ys = [c["x"] for c in STATE["proposals"]], [c["y"] for c in STATE["proposals"]]
    canvas.setExtent(QgsRectangle(min(xs) - 100, min(ys) - 100, max(xs) + 100, max(ys) + 100))
    click(dock.tools[MAP], map_screen(dock, second["x"], second["y"]), Qt.RightButton)
    STATE["clicked"] = {"gcps": gcps(dock), "left": len(dock.controller.proposals)}
    STATE["accepted"] = len(dock.controller.accept_proposals(check_every=3))
    STATE["fit"] = fitted(dock)
    STATE["summary"] = dock.summary.text()
    STATE["gcps"] = gcps(dock)
    # the tools on the accepted GCPs: orient's report and the orthorectified frame (DEM), each in a task
    done = {}
    for kind, name in (("report", "orient.json"), ("rectify", "rectified.tif")):
        dock.run_orient(kind, os.path.join(ARGS["out"], name), on_done=lambda ok, r, e, k=kind: done.update({k: [ok, e]}))
    # Rectify's options (what its dialog returns): resampling, pixel size and another CRS; the report as HTML
    dock.run_orient("rectify", os.path.join(ARGS["out"], "rectified_utm34.tif"),
                    on_done=lambda ok, r, e: done.update({"options": [ok, e]}),
                    extra={"resampling": "bilinear", "resolution": 12.5}, crs=QgsCoordinateReferenceSystem("EPSG:32734"))
    dock.run_orient("report", os.path.join(ARGS["out"], "orient.html"), on_done=lambda ok, r, e: done.update(html=[ok, e]))
    start = time.monotonic()
    while len(done) < 4 and time.monotonic() - start < 600:
        pump(0.2)
    STATE["runs"] = done
    # RPC export: orient's own refusal for a DLT, then the RFM's RPC00B written into a copy of the frame
    rpc = {}
    dock.run_orient("rpc", os.path.join(ARGS["out"], "rpc_dlt.tif"), on_done=lambda ok, r, e: rpc.update(dlt=[ok, e]))
    while "dlt" not in rpc and time.monotonic() - start < 600:
        pump(0.2)
    dock.model_combo.setCurrentText("rfm")
    STATE["rfm_fit"] = {k: v for k, v in fitted(dock).items() if k in ("ok", "model", "rms", "message")}
    dock.run_orient("rpc", os.path.join(ARGS["out"], "rpc.tif"), on_done=lambda ok, r, e: rpc.update(rfm=[ok, e]))
    while "rfm" not in rpc and time.monotonic() - start < 600:
        pump(0.2)
    STATE["rpc"] = rpc
    STATE["layers"] = sorted(layer.name() for layer in QgsProject.instance().mapLayers().values())


if __name__ == "__main__":
    run(propose if ARGS.get("mode") == "propose" else main, STATE, ARGS["out"])
