"""The picker's map tools, one on the image canvas and one on QGIS's map canvas.

- left click on empty space: one half of a GCP (the image point, then the map point, or the other
  way round; the controller pairs them);
- left drag starting on a GCP: move that GCP's position on this canvas;
- right click on a GCP: delete it (undo brings it back);
- left / right click on a proposed GCP (cyan square): accept / reject it;
- moving the cursor: the controller shows on the *other* canvas where the current model puts
  this position (the predicted next click).

On the map canvas clicks snap to the vertices/segments of the project's vector layers according
to QGIS's own snapping settings (the canvas's :class:`QgsSnappingUtils`, i.e. Project > Snapping
Options / the snapping toolbar), and the usual :class:`QgsSnapIndicator` shows the snap.
"""
from __future__ import annotations

from qgis.gui import QgsMapTool, QgsSnapIndicator
from qgis.PyQt.QtCore import Qt

IMAGE, MAP = "image", "map"
#: a press closer than this (screen pixels) to a GCP grabs it
GRAB_TOLERANCE_PX = 10
#: a drag shorter than this (screen pixels) is a click, not a move
DRAG_THRESHOLD_PX = 2


class PickTool(QgsMapTool):
    """Click / drag / delete GCPs on one canvas (``side`` is :data:`IMAGE` or :data:`MAP`)."""

    def __init__(self, canvas, controller, side: str):
        super().__init__(canvas)
        self.controller, self.side = controller, side
        self.snap_indicator = QgsSnapIndicator(canvas) if side == MAP else None
        self.dragging = None  # (gcp id, press position on screen)
        self.setCursor(Qt.CursorShape.CrossCursor)

    def _position(self, event):
        """The event's position in canvas coordinates; snapped on the map canvas (QGIS's settings)."""
        if self.side != MAP:
            return event.mapPoint()
        point = event.snapPoint()
        if self.snap_indicator is not None:
            self.snap_indicator.setMatch(event.mapPointMatch())
        return point

    def canvasPressEvent(self, event):  # noqa: N802 - QGIS's name
        proposal = self.controller.nearest_proposal(self.side, event.pos(), GRAB_TOLERANCE_PX)
        if proposal is not None and event.button() in (Qt.MouseButton.LeftButton, Qt.MouseButton.RightButton):
            if event.button() == Qt.MouseButton.LeftButton:
                self.controller.accept_proposals([proposal])
            else:
                self.controller.reject_proposals([proposal])
            return
        near = self.controller.nearest(self.side, event.pos(), GRAB_TOLERANCE_PX)
        if event.button() == Qt.MouseButton.RightButton:
            if near is not None:
                self.controller.delete(near)
            else:
                self.controller.cancel_pending()
            return
        if event.button() != Qt.MouseButton.LeftButton:
            return
        if near is not None:
            self.dragging = (near, event.pos())
            self.controller.select(near)
            return
        self.controller.place(self.side, self._position(event))

    def canvasMoveEvent(self, event):  # noqa: N802
        point = self._position(event)
        if self.dragging is not None:
            self.controller.preview_move(self.side, self.dragging[0], point)
        else:
            self.controller.hover(self.side, point)

    def canvasReleaseEvent(self, event):  # noqa: N802
        if self.dragging is None:
            return
        gcp_id, start = self.dragging
        self.dragging = None
        moved = (event.pos() - start).manhattanLength() > DRAG_THRESHOLD_PX
        if moved:
            self.controller.move(self.side, gcp_id, self._position(event))
        else:
            self.controller.show()

    def deactivate(self):
        if self.snap_indicator is not None:
            self.snap_indicator.setMatch(type(self.snap_indicator.match())())
        super().deactivate()
