"""What the picker draws over a canvas: GCP crosses with ids, residual arrows, the pending click,
the predicted position of the next click and the proposals waiting for accept/reject.

One :class:`PickerOverlay` per canvas (the image canvas and QGIS's map canvas) paints everything
in screen coordinates, so marks keep their size at every zoom. Positions are given in the
canvas's own coordinates (the controller transforms them). A residual arrow starts at the
measured point and points along the residual (model minus measurement), ``exaggeration`` times
its length, like ``fotogeo orient``'s error vectors.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from qgis.core import QgsPointXY
from qgis.gui import QgsMapCanvasItem
from qgis.PyQt.QtCore import QPointF, QRectF, Qt
from qgis.PyQt.QtGui import QBrush, QColor, QFont, QPainter, QPen, QPolygonF

COLOURS = {"control": QColor(30, 90, 230), "check": QColor(220, 30, 30), "flag": QColor(255, 140, 0),
           "pending": QColor(250, 220, 0), "predicted": QColor(0, 200, 80), "proposal": QColor(0, 220, 230),
           "selected": QColor(255, 0, 255), "disabled": QColor(150, 150, 150)}
CROSS = 8  # half size of a GCP cross, screen pixels: a 16 px mark, as QGIS's vertex markers
HALO = QColor(255, 255, 255, 230)  # drawn under every mark, so it stands out on dark and bright imagery alike


@dataclass
class Mark:
    """One GCP as drawn on one canvas: ``at`` its position, ``arrow_to`` the exaggerated residual's end."""

    label: str
    at: QgsPointXY
    role: str = "control"
    flagged: bool = False
    arrow_to: QgsPointXY | None = None


@dataclass
class Overlay:
    marks: list = field(default_factory=list)
    pending: QgsPointXY | None = None
    predicted: QgsPointXY | None = None
    proposals: list = field(default_factory=list)  # (QgsPointXY, label)
    selected: str | None = None


class PickerOverlay(QgsMapCanvasItem):
    """Paints an :class:`Overlay` over the whole visible extent of ``canvas``."""

    def __init__(self, canvas):
        super().__init__(canvas)
        self.canvas = canvas
        self.state = Overlay()
        self.setZValue(100)
        self.updatePosition()

    def show_state(self, state: Overlay) -> None:
        self.state = state
        self.updatePosition()
        self.update()

    def updatePosition(self):  # noqa: N802 - QGIS's name: called when the canvas extent changes
        self.setRect(self.canvas.extent())

    def _screen(self, point: QgsPointXY) -> QPointF:
        return self.toCanvasCoordinates(point) - self.pos()

    def paint(self, painter, option=None, widget=None):
        painter.setRenderHint(QPainter.RenderHint.Antialiasing, True)
        painter.setBrush(Qt.BrushStyle.NoBrush)
        font = QFont(painter.font())
        font.setPointSize(9)
        font.setBold(True)
        painter.setFont(font)
        for proposal, label in self.state.proposals:
            self._square(painter, self._screen(proposal), COLOURS["proposal"], label)
        for mark in self.state.marks:
            self._mark(painter, mark)
        if self.state.pending is not None:
            self._circle(painter, self._screen(self.state.pending), COLOURS["pending"], 9)
        if self.state.predicted is not None:
            self._circle(painter, self._screen(self.state.predicted), COLOURS["predicted"], 12, dashed=True)

    def _mark(self, painter, mark: Mark):
        colour = COLOURS["flag"] if mark.flagged else COLOURS.get(mark.role, COLOURS["check"])
        p = self._screen(mark.at)
        if mark.arrow_to is not None:
            self._arrow(painter, p, self._screen(mark.arrow_to), colour)
        selected = self.state.selected == mark.label
        width = 4 if selected else 3
        for pen in (QPen(HALO, width + 3), QPen(COLOURS["selected"] if selected else colour, width)):
            pen.setCapStyle(Qt.PenCapStyle.RoundCap)
            painter.setPen(pen)  # the halo, then the cross and its ring
            painter.drawLine(QPointF(p.x() - CROSS, p.y()), QPointF(p.x() + CROSS, p.y()))
            painter.drawLine(QPointF(p.x(), p.y() - CROSS), QPointF(p.x(), p.y() + CROSS))
            painter.drawEllipse(p, CROSS * 0.6, CROSS * 0.6)
        self._label(painter, p, mark.label, colour)

    @staticmethod
    def _label(painter, p: QPointF, text: str, colour: QColor):
        where = QPointF(p.x() + CROSS + 2, p.y() - CROSS)
        painter.setPen(QPen(HALO, 3))
        for dx, dy in ((-1, 0), (1, 0), (0, -1), (0, 1)):  # a light halo first, then the text
            painter.drawText(where + QPointF(dx, dy), text)
        painter.setPen(QPen(colour, 1))
        painter.drawText(where, text)

    @staticmethod
    def _arrow(painter, start: QPointF, end: QPointF, colour: QColor):
        length = math.hypot(end.x() - start.x(), end.y() - start.y())
        if length < 1.0:
            return
        painter.setPen(QPen(HALO, 4))
        painter.drawLine(start, end)
        painter.setPen(QPen(colour, 2))
        painter.drawLine(start, end)
        ux, uy = (end.x() - start.x()) / length, (end.y() - start.y()) / length
        head = min(10.0, length / 2)
        left = QPointF(end.x() - head * ux + head * 0.5 * uy, end.y() - head * uy - head * 0.5 * ux)
        right = QPointF(end.x() - head * ux - head * 0.5 * uy, end.y() - head * uy + head * 0.5 * ux)
        painter.setBrush(QBrush(colour))
        painter.drawPolygon(QPolygonF([end, left, right]))
        painter.setBrush(Qt.BrushStyle.NoBrush)

    @staticmethod
    def _circle(painter, p: QPointF, colour: QColor, radius: float, dashed: bool = False):
        for pen in (QPen(HALO, 5), QPen(colour, 3)):
            if dashed:
                pen.setStyle(Qt.PenStyle.DashLine)
            painter.setPen(pen)
            painter.drawEllipse(p, radius, radius)
            painter.drawPoint(p)

    def _square(self, painter, p: QPointF, colour: QColor, label: str):
        for pen in (QPen(HALO, 5), QPen(colour, 2)):
            painter.setPen(pen)
            painter.drawRect(QRectF(p.x() - 7, p.y() - 7, 14, 14))
        self._label(painter, p, label, colour)

    def remove(self):
        scene = self.canvas.scene()
        if scene is not None and self.scene() is scene:
            scene.removeItem(self)
