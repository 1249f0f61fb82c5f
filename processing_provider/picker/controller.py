"""The picker's state between the canvases, the GCP layer, the undo stack and the worker session.

Coordinates: the image canvas shows pixels as x = col, y = −row (:mod:`.image_source`); the GCP
layer holds map positions in its own CRS; QGIS's map canvas may use another CRS (the project's):
every map click is transformed canvas CRS → layer CRS, every mark layer CRS → canvas CRS.

A GCP is made of two clicks, one per canvas, in either order: the first one stays *pending*
(a yellow circle) until the other canvas is clicked. After every change the model is refitted
(:func:`.fit.fit`), the layer's result fields, the table and both overlays are refreshed.

The refit runs off the GUI thread: :meth:`PickerController.refit` reads the GCPs and the settings,
hands them to a thread that makes the worker session's call, and returns; the result comes back
through a queued signal. Each refit has a generation number: only the newest result is applied
(an older one that arrives later is dropped); while one runs, newer requests replace each other
and only the last is started when it ends. :attr:`PickerController.busy` says whether a result is
still to come.
"""
from __future__ import annotations

import threading
from dataclasses import replace

from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsPointXY, QgsProject
from qgis.PyQt.QtCore import QObject, pyqtSignal
from qgis.PyQt.QtWidgets import QUndoStack

from . import fit as fitting
from .canvas_items import Mark, Overlay, PickerOverlay
from .commands import AddGcps, DeleteGcps, UpdateGcp
from .gcp_layer import Gcp, GcpLayer
from .map_tools import IMAGE, MAP


class PickerController(QObject):
    """Places, moves, deletes GCPs (undoable), refits and draws; the dock shows :attr:`fit`."""

    fitted = pyqtSignal(dict)
    message = pyqtSignal(str)
    _fit_done = pyqtSignal(int, dict)  # generation, fit_gcps' result: from the fit thread

    def __init__(self, image_canvas, map_canvas, session, settings_fn):
        super().__init__()
        self.canvases = {IMAGE: image_canvas, MAP: map_canvas}
        self.session, self.settings_fn = session, settings_fn
        self.overlays = {side: PickerOverlay(c) for side, c in self.canvases.items()}
        self.undo_stack = QUndoStack(self)
        self.undo_stack.indexChanged.connect(lambda _index: self.refit())
        self.store: GcpLayer | None = None
        self.image = None
        self.fit: dict = {"ok": False, "message": "choose an image and a GCP layer", "points": [], "rms": {}}
        self.pending = None  # (side, (col, row) or (x, y) in the layer CRS)
        self.predicted = {IMAGE: None, MAP: None}
        self.proposals: list[dict] = []  # {"col", "row", "x", "y", "score"} (x, y in the layer CRS)
        self.exaggeration = 10.0
        self.selected = None
        self.generation, self.running, self.pending_fit = 0, False, None
        self._fit_done.connect(self._fit_finished)

    # -- setup ------------------------------------------------------------------------------
    def set_store(self, store: GcpLayer | None):
        if self.store is not None:
            self.store.changed.disconnect(self.refit)
        self.store = store
        self.pending, self.predicted, self.proposals = None, {IMAGE: None, MAP: None}, []
        self.undo_stack.clear()
        if store is not None:
            store.changed.connect(self.refit)
        self.refit()

    def set_image(self, image):
        self.image = image
        self.pending = None
        self.refit()

    def _to_layer(self) -> QgsCoordinateTransform:
        return QgsCoordinateTransform(self.canvases[MAP].mapSettings().destinationCrs(), self.store.crs,
                                      QgsProject.instance())

    def map_to_layer(self, point: QgsPointXY) -> tuple[float, float]:
        p = self._to_layer().transform(point)
        return p.x(), p.y()

    def layer_to_map(self, x: float, y: float) -> QgsPointXY:
        return self._to_layer().transform(QgsPointXY(x, y), QgsCoordinateTransform.ReverseTransform)

    def _side_position(self, side: str, point: QgsPointXY) -> tuple[float, float]:
        """A canvas position as GCP coordinates: (col, row) on the image, (x, y) in the layer CRS on the map."""
        return (point.x(), -point.y()) if side == IMAGE else self.map_to_layer(point)

    def _canvas_point(self, side: str, gcp_or_xy) -> QgsPointXY:
        if isinstance(gcp_or_xy, Gcp):
            gcp_or_xy = (gcp_or_xy.col, gcp_or_xy.row) if side == IMAGE else (gcp_or_xy.x, gcp_or_xy.y)
        a, b = gcp_or_xy
        return QgsPointXY(a, -b) if side == IMAGE else self.layer_to_map(a, b)

    def _ready(self) -> bool:
        if self.store is None or self.image is None:
            self.message.emit("choose the image and the GCP layer first")
            return False
        return True

    # -- edits (undoable) -------------------------------------------------------------------
    def place(self, side: str, point: QgsPointXY):
        """One click: completes the pending half on the other canvas into a GCP, or becomes pending."""
        if not self._ready():
            return
        here = self._side_position(side, point)
        if side == IMAGE and not self.image.inside(*here):
            self.message.emit(f"({here[0]:.1f}, {here[1]:.1f}) px is {self.image.outside()}")
            return
        if self.pending is None or self.pending[0] == side:
            self.pending = (side, here)
            self.show()
            where = f"({here[0]:.1f}, {here[1]:.1f}) px on the image" if side == IMAGE else "the map point"
            self.message.emit(f"{where} noted: now click the same point on the {'map' if side == IMAGE else 'image'}")
            return
        other = self.pending[1]
        (col, row), (x, y) = (here, other) if side == IMAGE else (other, here)
        self.pending = None
        self.add([Gcp(self.store.next_id(), col, row, x, y)])

    def add(self, gcps: list[Gcp], text: str = ""):
        if gcps:
            self.undo_stack.push(AddGcps(self.store, gcps, text))

    def move(self, side: str, gcp_id: str, point: QgsPointXY):
        before = self.gcp(gcp_id)
        if before is None:
            return
        a, b = self._side_position(side, point)
        if side == IMAGE and not self.image.inside(a, b):
            self.message.emit(f"({a:.1f}, {b:.1f}) px is {self.image.outside()}: GCP {gcp_id} not moved")
            self.show()
            return
        after = replace(before, col=a, row=b) if side == IMAGE else replace(before, x=a, y=b)
        self.undo_stack.push(UpdateGcp(self.store, before, after, f"move GCP {gcp_id} on the {side}"))

    def delete(self, gcp_id: str):
        gcp = self.gcp(gcp_id)
        if gcp is not None:
            self.undo_stack.push(DeleteGcps(self.store, [gcp]))

    def set_role(self, gcp_id: str, role: str):
        gcp = self.gcp(gcp_id)
        if gcp is not None and gcp.role != role:
            self.undo_stack.push(UpdateGcp(self.store, gcp, replace(gcp, role=role), f"GCP {gcp_id}: {role}"))

    def set_enabled(self, gcp_id: str, enabled: bool):
        """Enable (used, with its role) or disable (ignored, the Georeferencer's unticked 'enable') a GCP."""
        gcp = self.gcp(gcp_id)
        if gcp is not None and gcp.enabled != enabled:
            self.undo_stack.push(UpdateGcp(self.store, gcp, replace(gcp, enabled=enabled),
                                           f"GCP {gcp_id}: {'enabled' if enabled else 'disabled'}"))

    def set_height(self, gcp_id: str, z):
        gcp = self.gcp(gcp_id)
        if gcp is not None and gcp.z != z:
            self.undo_stack.push(UpdateGcp(self.store, gcp, replace(gcp, z=z), f"GCP {gcp_id}: height"))

    def cancel_pending(self):
        self.pending = None
        self.show()

    def select(self, gcp_id: str | None):
        self.selected = gcp_id
        self.show()

    def gcp(self, gcp_id: str) -> Gcp | None:
        return next((g for g in self.store.gcps() if g.id == gcp_id), None) if self.store else None

    # -- fit and drawing --------------------------------------------------------------------
    def settings(self) -> fitting.FitSettings:
        s = self.settings_fn()
        if self.image is not None:
            s = replace(s, image=self.image.path, width=self.image.width, height_px=self.image.height)
        if self.store is not None:
            s = replace(s, crs=self.store.crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED))
        return s

    @property
    def busy(self) -> bool:
        """A refit is running or waiting: :attr:`fit` is not yet the current GCPs' one."""
        return self.running or self.pending_fit is not None

    def current_fit(self) -> dict:
        """The fit of the GCPs as they are now, for an action that needs it at once (an export, a run): :attr:`fit`,
        or while a refit is under way one made here."""
        if not self.busy or self.store is None or self.image is None:
            return self.fit
        return fitting.fit(self.session, self.store.gcps(), self.settings())

    def refit(self):
        """Refit the model to the current GCPs off the GUI thread (module docstring); the result is applied by
        :meth:`_apply` (residuals stored, canvases redrawn, ``fitted`` emitted)."""
        self.generation += 1
        gcps = self.store.gcps() if self.store is not None and self.image is not None else None
        if not gcps:  # nothing to send to the worker: the answer is known at once
            self.pending_fit = None
            self._apply({"ok": False, "message": "choose the image and the GCP layer first", "points": [],
                         "rms": {}} if gcps is None else fitting.fit(self.session, gcps, self.settings()))
            return
        self.pending_fit = (self.generation, gcps, self.settings())
        self._start_fit()

    def _start_fit(self):
        if self.running or self.pending_fit is None:
            return
        generation, gcps, settings = self.pending_fit
        self.pending_fit, self.running = None, True
        threading.Thread(target=self._fit_in_thread, args=(generation, gcps, settings), daemon=True).start()

    def _fit_in_thread(self, generation: int, gcps, settings):
        """In the fit thread: the session call only, nothing of the GUI or the layer."""
        self._fit_done.emit(generation, fitting.fit(self.session, gcps, settings))

    def _fit_finished(self, generation: int, fit: dict):
        self.running = False
        if generation == self.generation:  # the newest request: applied; older ones are dropped
            self._apply(fit)
        self._start_fit()

    def _apply(self, fit: dict):
        self.fit = fit
        if self.store is not None and self.image is not None:
            self.store.write_results(fit)
        self._grids = (fitting.Grid.forward(fit), fitting.Grid.inverse(fit)) if fit.get("ok") else (None, None)
        self.show()
        self.fitted.emit(fit)

    def nearest(self, side: str, screen_pos, tolerance: float):
        """The id of the GCP drawn within ``tolerance`` screen pixels of ``screen_pos`` on ``side``, or None."""
        if self.store is None:
            return None
        to_screen = self.canvases[side].getCoordinateTransform()
        best = None
        for g in self.store.gcps():
            p = to_screen.transform(self._canvas_point(side, g))
            d = ((p.x() - screen_pos.x()) ** 2 + (p.y() - screen_pos.y()) ** 2) ** 0.5
            if d <= tolerance and (best is None or d < best[0]):
                best = (d, g.id)
        return best[1] if best else None

    def nearest_proposal(self, side: str, screen_pos, tolerance: float):
        """The index of the proposal drawn within ``tolerance`` screen pixels of ``screen_pos``, or None."""
        to_screen = self.canvases[side].getCoordinateTransform()
        best = None
        for i, c in enumerate(self.proposals):
            p = to_screen.transform(self._canvas_point(side, (c["col"], c["row"]) if side == IMAGE else (c["x"], c["y"])))
            d = ((p.x() - screen_pos.x()) ** 2 + (p.y() - screen_pos.y()) ** 2) ** 0.5
            if d <= tolerance and (best is None or d < best[0]):
                best = (d, i)
        return best[1] if best else None

    def predict(self, side: str, point: QgsPointXY):
        """Where the model puts ``point`` (on canvas ``side``) on the other canvas, or None."""
        forward, inverse = getattr(self, "_grids", (None, None))
        a, b = self._side_position(side, point)
        if side == IMAGE:
            xy = forward(a, b) if forward else None
            return self._canvas_point(MAP, xy) if xy else None
        colrow = inverse(a, b) if inverse else None
        return self._canvas_point(IMAGE, colrow) if colrow else None

    def hover(self, side: str, point: QgsPointXY):
        other = MAP if side == IMAGE else IMAGE
        if self.store is None or self.image is None:
            return
        self.predicted = {side: None, other: self.predict(side, point)}
        for s, overlay in self.overlays.items():  # only the prediction moves: no re-read of the GCPs per mouse move
            overlay.state.predicted = self.predicted[s]
            overlay.update()

    def preview_move(self, side: str, gcp_id: str, point: QgsPointXY):
        gcp = self.gcp(gcp_id)
        if gcp is None:
            return
        state = self._overlay(side)
        for mark in state.marks:
            if mark.label == gcp_id:
                mark.at, mark.arrow_to = point, None
        self.overlays[side].show_state(state)

    def _marks(self, side: str) -> list[Mark]:
        rows = {p["id"]: p for p in self.fit.get("points", [])} if self.fit.get("ok") else {}
        marks = []
        for g in self.store.gcps():
            r = rows.get(g.id, {})
            at = self._canvas_point(side, g)
            arrow = None
            if side == IMAGE and r.get("dx_px") is not None:
                k = self.exaggeration
                arrow = QgsPointXY(g.col + k * r["dx_px"], -(g.row + k * r["dy_px"]))
            elif side == MAP and r.get("dx_map") is not None:
                k = self.exaggeration
                arrow = self.layer_to_map(g.x + k * r["dx_map"], g.y + k * r["dy_map"])
            marks.append(Mark(g.id, at, g.role if g.enabled else "disabled", fitting.alarming(r.get("flag")), arrow))
        return marks

    def _overlay(self, side: str) -> Overlay:
        if self.store is None:
            return Overlay()
        pending = None
        if self.pending is not None and self.pending[0] == side:
            pending = self._canvas_point(side, self.pending[1])
        proposals = [(self._canvas_point(side, (c["col"], c["row"]) if side == IMAGE else (c["x"], c["y"])),
                      f"?{i + 1}") for i, c in enumerate(self.proposals)]
        return Overlay(self._marks(side), pending, self.predicted.get(side), proposals, self.selected)

    def show(self):
        for side, overlay in self.overlays.items():
            overlay.show_state(self._overlay(side))

    # -- proposals ------------------------------------------------------------------------------
    def set_proposals(self, result: dict):
        """Candidates of ``propose_gcps`` (map positions in ``result['crs']``) as markers to accept/reject."""
        source = QgsCoordinateReferenceSystem.fromWkt(result.get("crs") or "")
        to_layer = QgsCoordinateTransform(source, self.store.crs, QgsProject.instance()) if source.isValid() else None
        self.proposals = []
        for c in result.get("candidates", []):
            p = QgsPointXY(c["x"], c["y"])
            if to_layer is not None:
                p = to_layer.transform(p)
            self.proposals.append({**c, "x": p.x(), "y": p.y()})
        self.show()
        self.message.emit(f"{len(self.proposals)} proposed GCPs: accept or reject them")

    def accept_proposals(self, indices=None, check_every: int = 0):
        """Add the proposals ``indices`` (all by default) as GCPs in one undo step; every
        ``check_every``-th one (if > 0) becomes a check point."""
        chosen = sorted(range(len(self.proposals)) if indices is None else set(indices))
        used, gcps, n = {g.id for g in self.store.gcps()}, [], 1
        for k, i in enumerate(chosen):
            while str(n) in used:
                n += 1
            used.add(str(n))
            c = self.proposals[i]
            role = "check" if check_every and (k + 1) % check_every == 0 else "control"
            gcps.append(Gcp(str(n), c["col"], c["row"], c["x"], c["y"], None, role))
        self.reject_proposals(chosen)
        self.add(gcps, f"accept {len(gcps)} proposed GCPs")
        return gcps

    def reject_proposals(self, indices=None):
        drop = set(range(len(self.proposals)) if indices is None else indices)
        self.proposals = [c for i, c in enumerate(self.proposals) if i not in drop]
        self.show()

    def close(self):
        self.generation += 1  # a fit still running is dropped when it arrives
        self.pending_fit = None
        for overlay in self.overlays.values():
            overlay.remove()
