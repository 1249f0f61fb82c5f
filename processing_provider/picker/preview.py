"""The picker's live preview: the image warped onto QGIS's map canvas with the current model.

After every refit that gives a model (and after every pan or zoom of the map canvas) the dock asks
:class:`LivePreview` for a new picture; a background thread sends the GCPs, the fit settings and
the canvas's extent, CRS and size to fotogeo's ``preview_warp`` (:mod:`fotogeo.tools.gcp.preview`)
in a worker session of its own (a second process: the picker's refits never wait behind a warp)
and reads the raw RGBA it writes into a :class:`QImage`. :class:`PreviewItem` draws it over the
map at the extent it was computed for, with the dock's opacity, under the picker's marks.

Requests carry a generation number: only the newest is shown, an older one that finishes later is
dropped; while one runs, newer requests replace each other and only the last is started when it
ends (a drag of ten edits costs at most two warps, never a queue).
"""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import threading
import time

from qgis.core import QgsCoordinateReferenceSystem, QgsPointXY, QgsRectangle
from qgis.gui import QgsMapCanvasItem
from qgis.PyQt.QtCore import QObject, QPointF, QRectF, pyqtSignal
from qgis.PyQt.QtGui import QImage

OPACITY = 0.6  # the default: the map shows through the warped image
#: the preview folders this process made and has not removed: a dock never closed properly (QGIS killed, a script
#: ending with os._exit) left them in the temporary folder; they go at interpreter exit and the plugin's unload
_FOLDERS: set[str] = set()


def new_folder() -> str:
    """A new ``fotogeo-preview-*`` temporary folder, remembered until :func:`remove_folder`."""
    folder = tempfile.mkdtemp(prefix="fotogeo-preview-")
    _FOLDERS.add(folder)
    return folder


#: removal attempts: a warp still running in the worker process may write ``preview.rgba.part`` into the folder
#: while it is being removed (the folder is then not empty when its entries are gone); it is removed again
REMOVE_ATTEMPTS = 20
REMOVE_WAIT_S = 0.05


def remove_folder(folder: str | None) -> None:
    """Remove ``folder`` and what a warp still in flight writes into it meanwhile (:data:`REMOVE_ATTEMPTS`)."""
    if not folder:
        return
    for attempt in range(REMOVE_ATTEMPTS):
        shutil.rmtree(folder, ignore_errors=True)
        if not os.path.exists(folder):
            break
        time.sleep(REMOVE_WAIT_S)
    _FOLDERS.discard(folder)


@atexit.register
def remove_folders() -> None:
    """Remove every preview folder this process made and has not removed (interpreter exit, plugin unload; a
    process ending with ``os._exit`` calls it first)."""
    for folder in list(_FOLDERS):
        remove_folder(folder)


class PreviewItem(QgsMapCanvasItem):
    """A :class:`QImage` drawn over ``canvas`` at ``extent`` (a rectangle in the canvas CRS), ``opacity`` 0–1."""

    def __init__(self, canvas):
        super().__init__(canvas)
        self.canvas = canvas
        self.image: QImage | None = None
        self.extent: QgsRectangle | None = None
        self.opacity = OPACITY
        self.setZValue(50)  # above the layers, below the picker's marks (100)
        self.updatePosition()

    def show_image(self, image: QImage | None, extent: QgsRectangle | None = None):
        self.image, self.extent = image, extent
        self.updatePosition()
        self.update()

    def updatePosition(self):  # noqa: N802 - QGIS's name: called when the canvas extent changes
        self.setRect(self.canvas.extent())

    def paint(self, painter, option=None, widget=None):
        if self.image is None or self.extent is None:
            return
        top_left = self.toCanvasCoordinates(QgsPointXY(self.extent.xMinimum(), self.extent.yMaximum())) - self.pos()
        bottom_right = self.toCanvasCoordinates(QgsPointXY(self.extent.xMaximum(), self.extent.yMinimum())) - self.pos()
        painter.setOpacity(self.opacity)
        painter.setRenderHint(painter.SmoothPixmapTransform, True)
        painter.drawImage(QRectF(QPointF(top_left), QPointF(bottom_right)), self.image)

    def remove(self):
        scene = self.canvas.scene()
        if scene is not None and self.scene() is scene:
            scene.removeItem(self)


def read_rgba(result: dict) -> QImage:
    """The raw RGBA file of ``preview_warp``'s result as a QImage (a copy: the file may be rewritten)."""
    with open(result["output"], "rb") as f:
        data = f.read()
    w, h = int(result["width"]), int(result["height"])
    return QImage(data, w, h, 4 * w, QImage.Format.Format_RGBA8888).copy()


class LivePreview(QObject):
    """Runs ``preview_warp`` off the GUI thread and shows the newest result (module docstring).

    ``shown(result)`` fires when a picture is shown or cleared (tests, the dock's status)."""

    _done = pyqtSignal(int, dict, object)  # generation, result, QImage or None: from the worker thread
    shown = pyqtSignal(dict)

    def __init__(self, canvas, session=None):
        super().__init__()
        if session is None:
            from ..session import WorkerSession
            session = WorkerSession()
        self.canvas, self.session = canvas, session
        self.item = PreviewItem(canvas)
        self.enabled = True
        self.generation = 0
        self.running = False
        self.pending: tuple | None = None
        self.last: dict = {}
        self.folder: str | None = None  # made on the first warp (new_folder), removed on close
        self._done.connect(self._finished)

    def canvas_request(self) -> dict:
        """The canvas part of a request: its extent, CRS and size in pixels."""
        e = self.canvas.extent()
        crs = self.canvas.mapSettings().destinationCrs()
        return {"extent": [e.xMinimum(), e.yMinimum(), e.xMaximum(), e.yMaximum()],
                "extent_crs": crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED),
                "size": [max(1, self.canvas.width()), max(1, self.canvas.height())]}

    def request(self, fit_kwargs: dict | None):
        """Warp with ``fit_kwargs`` (``fit_gcps``'s arguments) over the current canvas; None (no model yet, or the
        preview switched off) clears the picture."""
        self.generation += 1
        if not self.enabled or not fit_kwargs:
            self.pending = None
            self.item.show_image(None)
            self.last = {"ok": False, "message": "no preview", "generation": self.generation}
            self.shown.emit(self.last)
            return
        if self.folder is None or not os.path.isdir(self.folder):
            self.folder = new_folder()
        kwargs = {**{k: v for k, v in fit_kwargs.items() if k != "image_sigma"},  # the blunder test's: not a warp's
                  **self.canvas_request(), "output": os.path.join(self.folder, "preview.rgba")}
        self.pending = (self.generation, kwargs)
        self._start_next()

    def _start_next(self):
        if self.running or self.pending is None:
            return
        generation, kwargs = self.pending
        self.pending, self.running = None, True
        threading.Thread(target=self._work, args=(generation, kwargs), daemon=True).start()

    def _work(self, generation: int, kwargs: dict):
        """In the worker thread: the session call and the file read, nothing of the GUI."""
        from ..session import SessionError
        image = None
        try:
            result = self.session.call("preview_warp", timeout=60, **kwargs)
            if result.get("ok"):
                image = read_rgba(result)
        except (SessionError, OSError, ValueError) as e:
            result = {"ok": False, "message": str(e)}
        self._done.emit(generation, result, image)

    def _finished(self, generation: int, result: dict, image):
        self.running = False
        if generation == self.generation:  # the newest request: shown; older ones are dropped
            extent = QgsRectangle(*result["extent"]) if result.get("ok") else None
            self.item.show_image(image if self.enabled else None, extent)
            self.last = {**result, "generation": generation}
            self.shown.emit(self.last)
        self._start_next()

    def set_opacity(self, opacity: float):
        self.item.opacity = opacity
        self.item.update()

    def set_visible(self, visible: bool):
        self.item.setVisible(visible)

    def close(self):
        """Remove the picture, end the preview's worker and delete its files."""
        self.generation += 1
        self.pending = None
        self.item.remove()
        self.session.close()
        remove_folder(self.folder)
