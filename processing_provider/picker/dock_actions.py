"""The picker dock's actions: proposals, import/export, and the tools run on the current GCPs.

- *Propose GCPs*: fotogeo's ``propose_gcps`` (SURF tie points between the image and a reference
  raster, the registration's robust fit, a grid budget over the image, LSM refinement) in a
  :class:`~.tasks.ToolTask`; its candidates appear as cyan squares to accept or reject.
- *Import / Export*: ``.points`` and ODM ``gcp_list.txt`` (:mod:`.files`); an import is one undo step.
- *Rectify / RPC / Report*: ``fotogeo orient`` on the GCP layer (written to a temporary
  GeoPackage) with the dock's model, heights and camera, in a task; a rectified raster is
  added to the project. Rectify asks for resampling, pixel size and output CRS
  (:mod:`.rectify_dialog`); Report writes HTML (or JSON); file dialogs start in the picker's last
  folder, else beside the image.
"""
from __future__ import annotations

import os
import shutil
import tempfile

from qgis.core import Qgis, QgsMessageLog, QgsProject, QgsRasterLayer
from qgis.gui import QgsMessageBarItem
from qgis.PyQt.QtWidgets import QFileDialog

from . import fit as fitting
from . import files, tasks
from .rectify_dialog import RectifyDialog, ground_resolution, remember, start_folder, suggested

#: orient's output keyword and the file filter of each run button
RUNS = {"rectify": ("rectify", "GeoTIFF (*.tif)"), "rpc": ("rpc", "GeoTIFF with RPC (*.tif)"),
        "report": ("report", "HTML report (*.html);;JSON report (*.json)")}


class DockActions:
    """Mixed into :class:`~.dock.PickerDock` (needs its controller, session, combos and ``say``)."""

    def say(self, text: str, level=Qgis.Info):
        """Show ``text`` under the canvas and on QGIS's message bar when there is one: a hint (info) replaces the
        previous hint there, so the step-by-step hints of every click do not stack up; warnings stay."""
        self.last_message = text
        self.summary.setText(text)
        QgsMessageLog.logMessage(text, "fotogeo picker", level)
        if self.message_bar is not None:
            old = getattr(self, "_hint", None)
            if old is not None:
                try:
                    self.message_bar.popWidget(old)
                except RuntimeError:  # already gone (its timeout): Qt deleted it
                    pass
            item = QgsMessageBarItem("fotogeo picker", text, level, 8)
            self.message_bar.pushItem(item)
            self._hint = item if level == Qgis.Info else None

    @staticmethod
    def describe_fit(fit: dict) -> str:
        line = fitting.summary(fit)
        if not fit.get("ok") and fit.get("needed"):
            line = f"{line} (the table fills once the model has enough control points)"
        return line

    def new_layer_dialog(self):
        path, _ = QFileDialog.getSaveFileName(self, "New GCP GeoPackage (cancel: a memory layer)",
                                              suggested(self.image.path if self.image is not None else None,
                                                        "_gcps.gpkg"), "GeoPackage (*.gpkg)")
        remember(path)
        try:
            self.new_gcp_layer(path=path or None)
        except ValueError as e:
            self.say(str(e))

    def _heights_chosen(self, source: str) -> None:
        """Heights = dem with no DEM chosen yet: preselect the project's likeliest DEM layer (fit.guess_dem)."""
        if source != "dem" or self.dem_combo.currentLayer() is not None:
            return
        image = self.image_combo.currentLayer()
        layers = [node.layer() for node in QgsProject.instance().layerTreeRoot().findLayers()
                  if isinstance(node.layer(), QgsRasterLayer)]
        name = fitting.guess_dem([(lay.name(), lay.bandCount()) for lay in layers],
                                 exclude=(image.name(),) if image is not None else ())
        if name is not None:
            self.dem_combo.setLayer(next(lay for lay in layers if lay.name() == name))

    # -- proposals ----------------------------------------------------------------------------
    def propose(self, reference: str | None = None, count: int | None = None):
        """Start ``propose_gcps`` of the image against ``reference`` (default: the chosen raster layer)."""
        layer = self.reference_combo.currentLayer()
        reference = reference or (layer.source() if layer is not None else None)
        if not reference or self.image is None or self.controller.store is None:
            self.say("Propose GCPs needs the image, a GCP layer and a reference raster (an orthophoto)", Qgis.Warning)
            return None
        kwargs = {"image": self.image.path, "reference": reference, "count": count or self.count_spin.value()}
        dem = self.dem_combo.currentLayer()
        if dem is not None:
            kwargs["dem"] = dem.source()
        self.propose_button.setEnabled(False)
        self.say("proposing GCPs (task manager: progress and cancel)")
        task = tasks.start("fotogeo picker: propose GCPs", "propose_gcps", kwargs, self._proposals_done)
        self.tasks.append(task)
        return task

    def _proposals_done(self, ok, result, error):
        self.propose_button.setEnabled(True)
        if not ok:
            self.say(f"Propose GCPs: {error}", Qgis.Warning)
            return
        self.controller.set_proposals(result)

    # -- files ----------------------------------------------------------------------------------
    def import_dialog(self):
        path, _ = QFileDialog.getOpenFileName(self, "Import GCPs", start_folder(self._image_path()),
                                              "Georeferencer points (*.points);;ODM gcp_list (*.txt)")
        if path:
            remember(path)
            self.import_file(path)

    def export_dialog(self):
        path, _ = QFileDialog.getSaveFileName(self, "Export GCPs", suggested(self._image_path(), ".points"),
                                              "Georeferencer points (*.points);;ODM gcp_list (*.txt)")
        if path:
            remember(path)
            self.export_file(path)

    def _image_path(self) -> str | None:
        return self.image.path if self.image is not None else None

    def import_file(self, path: str) -> int:
        """Add the GCPs of a ``.points`` or ``gcp_list.txt`` file (one undo step); the count, 0 on failure."""
        from ..session import SessionError
        store = self.controller.store
        if store is None or self.image is None:
            self.say("choose the image and the GCP layer before importing", Qgis.Warning)
            return 0
        try:
            if path.lower().endswith(".points"):
                gcps = files.import_points(self.session, path, store)
            else:
                gcps = files.import_gcp_list(self.session, path, self.image.path, store)
        except (files.PickerFileError, SessionError, ValueError) as e:
            self.say(str(e), Qgis.Warning)
            return 0
        self.controller.add(gcps, f"import {len(gcps)} GCPs")
        self.say(f"{len(gcps)} GCPs imported from {os.path.basename(path)}")
        return len(gcps)

    def export_file(self, path: str) -> bool:
        from ..session import SessionError
        store = self.controller.store
        if store is None:
            self.say("no GCP layer to export", Qgis.Warning)
            return False
        try:
            if path.lower().endswith(".points"):
                files.export_points(self.session, store, path)
            else:
                files.export_gcp_list(self.session, store, self.controller.current_fit(), self.image.path, path)
        except (files.PickerFileError, SessionError, RuntimeError) as e:
            self.say(str(e), Qgis.Warning)
            return False
        self.say(f"{len(store.gcps())} GCPs written to {path}")
        return True

    # -- tools on the current GCPs --------------------------------------------------------------
    def run_dialog(self, kind: str):
        if kind == "rectify":
            return self.rectify_dialog()
        key, file_filter = RUNS[kind]
        suffix = {"rpc": "_rpc.tif", "report": "_report.html"}[kind]
        path, _ = QFileDialog.getSaveFileName(self, f"fotogeo orient: {kind}", suggested(self._image_path(), suffix),
                                              file_filter)
        if path:
            remember(path)
            self.run_orient(kind, path)

    def rectify_dialog(self):
        """Rectify's options (output, resampling, pixel size, CRS), then the run."""
        store = self.controller.store
        fit = self.controller.fit
        map_crs = self.map_canvas.mapSettings().destinationCrs()
        gsd = ground_resolution(fit) if fit.get("ok") and store is not None and \
            store.layer.crs().mapUnits() == map_crs.mapUnits() else None  # the fit's grid is in the layer's CRS
        dlg = RectifyDialog(self, self._image_path(), map_crs, resolution=gsd)
        if not dlg.exec() or not dlg.choices()["path"]:
            return None
        c = dlg.choices()
        remember(c["path"])
        return self.run_orient("rectify", c["path"], extra={"resampling": c["resampling"],
                                                            "resolution": c["resolution"]}, crs=c["crs"])

    def orient_arguments(self, crs=None) -> dict:
        """``orient``'s keyword arguments for the dock's model, heights and camera (GCPs: a temporary GeoPackage,
        transformed into ``crs`` when given)."""
        s = self.controller.settings()
        folder = tempfile.mkdtemp(prefix="fotogeo-picker-")
        # without the z field unless the heights come from it: orient then uses the DEM / the constant for every
        # point, as the dock's fit does
        gpkg = self.controller.store.export_gpkg(os.path.join(folder, "gcps.gpkg"), heights=s.height_source == "field",
                                                 crs=crs)
        kwargs = {"image": self.image.path, "gcps": gpkg, "layer": "gcps", "model": s.model, "overwrite": True}
        if s.height_source == "dem" and s.dem:
            kwargs["dem"] = s.dem
        if s.height_source == "constant" and s.height is not None:
            kwargs["height"] = s.height
        if s.camera:
            kwargs["camera"] = s.camera
        if s.image_sigma:
            kwargs["image_sigma"] = s.image_sigma  # the report's blunder flags as the dock's
        return kwargs

    def run_orient(self, kind: str, output: str, on_done=None, extra: dict | None = None, crs=None):
        """``fotogeo orient`` with output ``kind`` (rectify, rpc, report) written to ``output``, in a task;
        ``extra``: more of orient's keyword arguments (resampling, resolution); ``crs``: the GCPs' (and so the
        output's) CRS."""
        fit = self.controller.current_fit()
        if self.controller.store is None or self.image is None or not fit.get("ok"):
            self.say(f"{kind}: first pick enough GCPs for the model ({fit.get('message', '')})",
                     Qgis.Warning)
            return None
        kwargs = {**self.orient_arguments(crs), **{k: v for k, v in (extra or {}).items() if v is not None},
                  RUNS[kind][0]: output}

        def done(ok, result, error):
            shutil.rmtree(os.path.dirname(kwargs["gcps"]), ignore_errors=True)
            if ok and kind == "rectify":
                QgsProject.instance().addMapLayer(QgsRasterLayer(output, os.path.basename(output)))
            self.say(f"{kind}: written to {output}" if ok else f"{kind}: {error}", Qgis.Success if ok else Qgis.Warning)
            if on_done is not None:
                on_done(ok, result, error)
        task = tasks.start(f"fotogeo picker: {kind}", "orient", kwargs, done)
        self.tasks.append(task)
        return task
