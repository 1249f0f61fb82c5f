"""Startup script (``qgis --code``) of tests/test_qgis_picker_desktop.py: the GCP picker in the real desktop.

Opens the dock through the plugin's menu action, picks GCPs by simulated clicks on the image canvas and on
QGIS's map canvas (over the reference orthophoto) — the live preview looked at one point before DLT's minimum
and at it, where a GCP is dragged on the map (the preview's pictures and the canvas saved before and after, the
drag undone) —, makes two of them check points, sorts the table by residual (header clicks), moves the cursor
to show the prediction, grabs screenshots (one with the orthophoto hidden: the preview alone); optionally runs
*Propose GCPs* and grabs the proposals. Writes ``result.json`` into ``FOTOGEO_DESKTOP_OUT`` and quits.
"""
import json
import os
import sys

from qgis.core import QgsProject, QgsRasterLayer, QgsRectangle
from qgis.PyQt.QtCore import QEvent, QPoint, Qt, QTimer
from qgis.PyQt.QtWidgets import QAction, QDockWidget
from qgis.utils import iface

ARGS = json.loads(open(os.environ["FOTOGEO_PICKER_ARGS"]).read())
OUT = ARGS["out"]
sys.path.insert(0, ARGS["tests"])
from desktop_harness import Harness  # noqa: E402
from picker_driver import IMAGE, MAP, drag, fitted, gcps, map_screen, mouse, pick, screen, sort_by, table  # noqa: E402

HARNESS = Harness(OUT)
STATE, finish, guard, grab = HARNESS.state, HARNESS.finish, HARNESS.guard, HARNESS.grab
KEEP = {}


@guard
def start():
    window = iface.mainWindow()
    window.resize(1600, 1000)
    project = QgsProject.instance()
    ortho = QgsRasterLayer(ARGS["ortho"], "reference orthophoto")
    KEEP["ortho"] = ortho
    dem = QgsRasterLayer(ARGS["dem"], "DEM")
    project.addMapLayer(dem, False)  # listed in the dock, not drawn over the map
    project.addMapLayer(ortho)
    crs = ortho.crs()
    KEEP["crs"] = crs
    project.setCrs(crs)
    xs, ys = [g["x"] for g in ARGS["gcps"]], [g["y"] for g in ARGS["gcps"]]
    iface.mapCanvas().setExtent(QgsRectangle(min(xs) - 150, min(ys) - 150, max(xs) + 150, max(ys) + 150))
    action = window.findChild(QAction, "fotogeoGcpPicker")
    STATE["action"] = action is not None and action.text()
    action.trigger()
    dock = window.findChild(QDockWidget, "FotogeoGcpPicker")
    KEEP["dock"] = dock
    STATE["dock_visible"] = dock.isVisible()
    window.resizeDocks([dock], [820], Qt.Horizontal)
    assert dock.open_image(ARGS["frame"]), dock.last_message
    dock.new_gcp_layer(crs)
    dock.model_combo.setCurrentText("dlt")
    dock.height_combo.setCurrentText("dem")
    dock.dem_combo.setLayer(dem)
    dock.exaggeration_spin.setValue(40)
    QTimer.singleShot(2500, picking)


def when_previewed(then, n=0):
    """``then()`` once the live preview has answered its newest request (polled from the event loop)."""
    p = KEEP["dock"].preview
    if (p.running or p.pending is not None or p.last.get("generation") != p.generation) and n < 300:
        QTimer.singleShot(200, guard(lambda: when_previewed(then, n + 1)))
        return
    then()


def preview_state(name=None):
    p = KEEP["dock"].preview
    shown = {"drawn": p.item.image is not None and p.item.isVisible(), "ok": p.last.get("ok"),
             "model": p.last.get("model"), "covered": p.last.get("covered")}
    if name and p.item.image is not None:
        p.item.image.save(os.path.join(OUT, name), "PNG")
    return shown


@guard
def picking():
    """GCPs one below DLT's minimum (6), the preview looked at; the sixth; the preview again; the rest."""
    dock = KEEP["dock"]
    for k, truth in enumerate(ARGS["gcps"][:5]):
        pick(dock, truth, image_first=k % 2 == 0)
    when_previewed(guard(lambda: (STATE.update(preview_below_minimum=preview_state()), minimum())))


@guard
def minimum():
    pick(KEEP["dock"], ARGS["gcps"][5], image_first=False)
    when_previewed(guard(lambda: (STATE.update(preview_at_minimum=preview_state()), dragging())))


@guard
def dragging():
    """At DLT's minimum, the control point farthest inside the image dragged on the map: the preview is redrawn;
    its pictures and the canvas before and after saved; the drag undone."""
    dock, canvas = KEEP["dock"], iface.mapCanvas()
    STATE["preview_before_drag"] = preview_state("preview_before.png")
    grab(canvas, "canvas_before.png")
    w, h = dock.image.width, dock.image.height
    g = max((g for g in dock.controller.store.gcps() if g.role == "control"),
            key=lambda g: min(g.col, w - g.col, g.row, h - g.row))  # the farthest from the image's edges
    start = map_screen(dock, g.x, g.y)
    STATE["drag"] = {"gcp": g.id, "screen": [start.x(), start.y()], "by": [15, -10],
                     "canvas": [canvas.width(), canvas.height()]}
    drag(dock.tools[MAP], start, start + QPoint(15, -10))
    moved = dock.controller.gcp(g.id)
    STATE["drag"]["moved_map"] = [moved.x - g.x, moved.y - g.y]

    def after():
        STATE["preview_after_drag"] = preview_state("preview_after.png")
        grab(canvas, "canvas_after.png")
        dock.controller.undo_stack.undo()
        when_previewed(the_rest)
    when_previewed(guard(lambda: QTimer.singleShot(1000, guard(after))))


@guard
def the_rest():
    dock = KEEP["dock"]
    for k, truth in enumerate(ARGS["gcps"][6:], 6):
        pick(dock, truth, image_first=k % 2 == 0)
    for gid in ("4", "9"):
        dock.controller.set_role(gid, "check")
    STATE["gcps"] = gcps(dock)
    STATE["fit"] = {k: v for k, v in fitted(dock).items() if k not in ("forward", "inverse")}
    STATE["summary"] = dock.summary.text()
    STATE["table"] = table(dock)
    sort_by(dock.table, "res px", Qt.DescendingOrder)  # the largest residual first, as a user checking the fit
    STATE["sorted_ids"] = [dock.table.item(r, 0).text() for r in range(dock.table.rowCount())]
    # the cursor over the image: the map shows where the model puts that pixel
    mouse(dock.tools[IMAGE], QEvent.MouseMove, screen(dock.image_canvas, 330, -560), Qt.NoButton)
    QTimer.singleShot(2500, guard(lambda: when_previewed(guard(lambda: (
        grab(iface.mainWindow(), "picker_dock.png", 1280), grab(dock, "picker_table.png"), preview_alone())))))


@guard
def preview_alone():
    """The orthophoto hidden: the live preview alone on the map (a screenshot), then shown again."""
    node = QgsProject.instance().layerTreeRoot().findLayer(KEEP["ortho"].id())
    node.setItemVisibilityChecked(False)

    def shot():
        grab(iface.mainWindow(), "picker_preview.png", 1280)
        node.setItemVisibilityChecked(True)
        QTimer.singleShot(1500, proposals)
    QTimer.singleShot(2000, guard(shot))


@guard
def proposals():
    if not ARGS.get("propose"):
        finish()
        return
    dock = KEEP["dock"]
    first = dock.controller.store.layer
    QgsProject.instance().layerTreeRoot().findLayer(first.id()).setItemVisibilityChecked(False)
    dock.new_gcp_layer(KEEP["crs"])
    KEEP["task"] = dock.propose(reference=ARGS["ortho"], count=30)
    wait_proposals(0)


@guard
def wait_proposals(n):
    dock = KEEP["dock"]
    if not dock.propose_button.isEnabled() and n < 600:
        QTimer.singleShot(500, guard(lambda: wait_proposals(n + 1)))
        return
    STATE["proposals"] = len(dock.controller.proposals)
    STATE["propose_error"] = KEEP["task"].error
    QTimer.singleShot(2000, guard(lambda: (grab(iface.mainWindow(), "picker_proposals.png", 1280), accept())))


@guard
def accept():
    """All proposals accepted, every third a check point: the live DLT fit and its residual arrows."""
    dock = KEEP["dock"]
    dock.controller.accept_proposals(check_every=3)
    dock.exaggeration_spin.setValue(150)  # sub-pixel residuals: arrows long enough to see
    fit = fitted(dock)
    STATE["accepted_fit"] = {"ok": fit["ok"], "model": fit.get("model"), "rms": fit.get("rms")}
    QTimer.singleShot(2000, guard(lambda: (grab(iface.mainWindow(), "picker_accepted.png", 1280), finish())))


QTimer.singleShot(3000, start)
