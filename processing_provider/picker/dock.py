"""The dock widget "fotogeo GCP picker": the image canvas, the controls, the residual table.

Layout, top to bottom: the image and GCP-layer choosers; the model (every fotogeo orientation
model, ``auto``, collinearity with a camera file), the height source (a DEM layer, the ``z``
field or a constant); the arrow exaggeration and the live preview's switch and opacity; the
proposal row (reference raster, count, Propose / Accept / Reject); the action row (undo, redo,
import, export, rectify, RPC, report); then a splitter: the image canvas above, the fit summary
and the table below, the image with the larger share (the table at least :data:`.table.MIN_ROWS` rows).
The handlers of the rows are in :mod:`.dock_actions`. The picking itself: :mod:`.map_tools` and :mod:`.controller`.
"""
from __future__ import annotations

import os

from qgis.core import (Qgis, QgsApplication, QgsCoordinateReferenceSystem, QgsMapLayerProxyModel, QgsMessageLog,
                       QgsProject, QgsTask)
from qgis.gui import QgsFileWidget, QgsMapCanvas, QgsMapLayerComboBox
from qgis.PyQt.QtCore import Qt, QTimer
from qgis.PyQt.QtGui import QKeySequence
from qgis.PyQt.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QDoubleSpinBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSpinBox,
    QSplitter,
    QVBoxLayout,
    QWidget,
)

from fotogeo.options import ORIENTATION_MODELS  # standard library only

from .commands import DeleteGcps
from .controller import PickerController
from .dock_actions import DockActions
from .fit import HEIGHT_SOURCES, FitSettings
from .gcp_layer import GcpLayer
from .image_source import ImageError, PickerImage
from .map_tools import IMAGE, MAP, PickTool
from .preview import OPACITY, LivePreview
from .table import GcpTable

#: the vertical split between the image canvas and the table (with the fit line above it): the image the larger,
#: it is where the user clicks
IMAGE_SHARE, TABLE_SHARE = 2, 1
#: the image canvas's smallest height (px): enough to find a point at a glance
MIN_IMAGE_HEIGHT = 260
#: "Accept all" keeps every 4th proposal (25 %, spread as the proposals are) as a check point
ACCEPT_CHECK_EVERY = 4
#: the click precision the dock assumes at first (px, 1σ): a careful click on a sharp point
CLICK_SIGMA = 1.0

MODELS = ("auto",) + ORIENTATION_MODELS
TITLE = "fotogeo GCP picker"


def _row(*widgets) -> QWidget:
    box = QWidget()
    layout = QHBoxLayout(box)
    layout.setContentsMargins(0, 0, 0, 0)
    for w in widgets:
        layout.addWidget(w)
    return box


class PickerDock(DockActions, QDockWidget):
    """The picker (module docstring). ``map_canvas`` is QGIS's main canvas; ``session`` a
    :class:`~processing_provider.session.WorkerSession` (default: the shared one)."""

    def __init__(self, map_canvas, parent=None, session=None, message_bar=None, preview_session=None):
        super().__init__(TITLE, parent)
        self.setObjectName("FotogeoGcpPicker")
        if session is None:
            from ..session import shared_session
            session = shared_session()
        self.map_canvas, self.session, self.message_bar = map_canvas, session, message_bar
        self.tasks, self.last_message, self.image = [], "", None
        self.image_canvas = QgsMapCanvas()
        self.image_canvas.setCanvasColor(Qt.GlobalColor.darkGray)
        self.image_canvas.setMinimumHeight(MIN_IMAGE_HEIGHT)
        self.controller = PickerController(self.image_canvas, map_canvas, session, self.fit_settings)
        self.tools = {IMAGE: PickTool(self.image_canvas, self.controller, IMAGE),
                      MAP: PickTool(map_canvas, self.controller, MAP)}
        self.preview = LivePreview(map_canvas, preview_session)
        self.preview.shown.connect(self._preview_shown)
        self._build()
        self.controller.fitted.connect(self._show_fit)
        map_canvas.extentsChanged.connect(self.update_preview)
        self.controller.message.connect(self.say)
        self.image_canvas.setMapTool(self.tools[IMAGE])
        self.activate_map_tool()
        self._start_worker()

    def _start_worker(self):
        """Start the session's worker in the background: its first start imports fotogeo (seconds), the
        refits after it are a JSON round trip, so the first click does not wait for the imports."""
        def warm_up(task):
            self.session.call("fit_gcps", gcps=[], model="affine", crs="EPSG:4326", timeout=120)
        self.warm_up = QgsTask.fromFunction("fotogeo picker: starting fotogeo's worker", warm_up)
        QgsApplication.taskManager().addTask(self.warm_up)

    # -- widgets ------------------------------------------------------------------------------
    def _build(self):
        self._build_inputs()
        form = QFormLayout()
        form.addRow("Image", _row(self.image_combo, self.image_file))
        form.addRow("GCP layer", _row(self.gcp_combo, self.new_layer_button))
        form.addRow("Model", _row(self.model_combo, QLabel("camera"), self.camera_file))
        form.addRow("Heights", _row(self.height_combo, self.dem_combo, self.height_spin))
        form.addRow("Click σ", self.sigma_spin)
        form.addRow("Arrows ×", self._display_row())
        form.addRow("Propose", self._proposal_row())
        controls = QWidget()
        layout = QVBoxLayout(controls)
        layout.setContentsMargins(4, 4, 4, 0)
        layout.addLayout(form)
        layout.addWidget(self._action_row())
        self.summary = QLabel("choose an image and a GCP layer, then click a point on the image and on the map")
        self.summary.setWordWrap(True)
        self.table = GcpTable()
        self.table.enabled_changed.connect(self.controller.set_enabled)
        self.table.role_changed.connect(self.controller.set_role)
        self.table.height_changed.connect(self.controller.set_height)
        self.table.gcp_selected.connect(self.controller.select)
        self.table.delete_requested.connect(self.delete_gcps)
        results = QWidget()
        layout = QVBoxLayout(results)
        layout.setContentsMargins(4, 0, 4, 0)
        layout.addWidget(self.summary)
        layout.addWidget(self.table, 1)
        self.splitter = QSplitter(Qt.Orientation.Vertical)  # the image and the table share what the controls leave
        self.splitter.addWidget(self.image_canvas)
        self.splitter.addWidget(results)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, IMAGE_SHARE)
        self.splitter.setStretchFactor(1, TABLE_SHARE)
        self.splitter.setSizes([IMAGE_SHARE * 100, TABLE_SHARE * 100])
        box = QWidget()
        layout = QVBoxLayout(box)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(controls)
        layout.addWidget(self.splitter, 1)
        self.setWidget(box)

    def _build_inputs(self):
        """The image, GCP layer, model and height widgets and their signals."""
        self.image_combo = QgsMapLayerComboBox()
        self.image_combo.setFilters(QgsMapLayerProxyModel.RasterLayer)
        self.image_combo.setAllowEmptyLayer(True)
        self.image_combo.setLayer(None)
        self.image_combo.layerChanged.connect(lambda layer: layer is not None and self.open_image(layer.source()))
        self.image_file = QgsFileWidget()
        self.image_file.setFilter("Images (*.tif *.tiff *.jpg *.jpeg *.png *.jp2 *.img *.vrt);;All files (*)")
        # typing a path: open it once it names a file (no "…RGB.ti is not a raster" per keystroke); a path that
        # names no file is reported when the typing ends
        self.image_file.fileChanged.connect(lambda path: path and os.path.isfile(path) and self.open_image(path))
        self.image_file.lineEdit().editingFinished.connect(self._image_path_typed)
        self.gcp_combo = QgsMapLayerComboBox()
        self.gcp_combo.setFilters(QgsMapLayerProxyModel.PointLayer)
        self.gcp_combo.setAllowEmptyLayer(True)
        self.gcp_combo.setLayer(None)
        self.gcp_combo.layerChanged.connect(self._gcp_layer_chosen)
        self.new_layer_button = new_layer = QPushButton("New")
        new_layer.setToolTip("A new GCP layer in the project CRS: a GeoPackage (or, when no file is chosen, a "
                             "memory layer)")
        new_layer.clicked.connect(self.new_layer_dialog)
        self.model_combo = QComboBox()
        self.model_combo.addItems(MODELS)
        self.model_combo.currentTextChanged.connect(lambda _text: self.controller.refit())
        self.camera_file = QgsFileWidget()
        self.camera_file.setFilter("Camera YAML (*.yaml *.yml)")
        self.camera_file.fileChanged.connect(lambda _p: self.controller.refit())
        self.height_combo = QComboBox()
        self.height_combo.addItems(HEIGHT_SOURCES)
        self.dem_combo = QgsMapLayerComboBox()
        self.dem_combo.setFilters(QgsMapLayerProxyModel.RasterLayer)
        self.dem_combo.setAllowEmptyLayer(True)
        self.dem_combo.setLayer(None)
        self.height_spin = QDoubleSpinBox()
        self.height_spin.setRange(-1000.0, 9000.0)
        self.height_combo.currentTextChanged.connect(self._heights_chosen)
        for w in (self.height_combo, self.dem_combo):
            (w.currentTextChanged if isinstance(w, QComboBox) and not isinstance(w, QgsMapLayerComboBox)
             else w.layerChanged).connect(lambda *_: self.controller.refit())
        self.height_spin.valueChanged.connect(lambda _v: self.controller.refit())
        self.sigma_spin = QDoubleSpinBox()  # the blunder test's a priori σ of a click (0: estimated from the fit)
        self.sigma_spin.setRange(0.0, 50.0)
        self.sigma_spin.setSingleStep(0.1)
        self.sigma_spin.setValue(CLICK_SIGMA)
        self.sigma_spin.setSuffix(" px")
        self.sigma_spin.setSpecialValueText("estimated from the fit")
        self.sigma_spin.setToolTip("How precisely you click (px, 1σ): the blunder test flags a point whose residual "
                                   "is too large for it; 0 estimates it from the residuals")
        self.sigma_spin.valueChanged.connect(lambda _v: self.controller.refit())
        self.exaggeration_spin = QDoubleSpinBox()
        self.exaggeration_spin.setRange(0.0, 100000.0)
        self.exaggeration_spin.setValue(self.controller.exaggeration)
        self.exaggeration_spin.valueChanged.connect(self._exaggeration_changed)

    def _proposal_row(self) -> QWidget:
        self.reference_combo = QgsMapLayerComboBox()
        self.reference_combo.setFilters(QgsMapLayerProxyModel.RasterLayer)
        self.reference_combo.setAllowEmptyLayer(True)
        self.reference_combo.setLayer(None)
        self.count_spin = QSpinBox()
        self.count_spin.setRange(4, 500)
        self.count_spin.setValue(30)
        buttons = [("Propose GCPs", self.propose),
                   ("Accept all", lambda: self.controller.accept_proposals(check_every=ACCEPT_CHECK_EVERY)),
                   ("Reject all", lambda: self.controller.reject_proposals())]
        widgets = [self.reference_combo, self.count_spin]
        for text, slot in buttons:
            b = QPushButton(text)
            b.clicked.connect(slot)
            widgets.append(b)
        self.propose_button = widgets[2]
        return _row(*widgets)

    def _display_row(self) -> QWidget:
        """The arrows' exaggeration, the live preview's switch and its opacity."""
        self.preview_check = QCheckBox("live preview")
        self.preview_check.setChecked(True)
        self.preview_check.setToolTip("After the model's minimum number of control points: the image warped onto "
                                      "the map with the current fit, redrawn after every change")
        self.preview_check.toggled.connect(self._preview_toggled)
        self.opacity_spin = QSpinBox()
        self.opacity_spin.setRange(0, 100)
        self.opacity_spin.setSuffix(" % opaque")
        self.opacity_spin.setValue(round(100 * OPACITY))
        self.opacity_spin.valueChanged.connect(lambda v: self.preview.set_opacity(v / 100.0))
        return _row(self.exaggeration_spin, self.preview_check, self.opacity_spin)

    def _preview_toggled(self, on: bool):
        self.preview.enabled = on
        self.update_preview()

    def update_preview(self, *_):
        """A new preview for the current fit and canvas (none while the model lacks points)."""
        c = self.controller
        ok = c.fit.get("ok") and c.store is not None and c.image is not None and self.isVisible()
        self.preview.request(c.settings().request(c.store.gcps()) if ok else None)

    def _preview_shown(self, result: dict):
        """A preview that failed although the fit worked (an unreadable image, a worker error) says why in the log."""
        if not result.get("ok") and result.get("message") not in (None, "no preview") and self.controller.fit.get("ok"):
            QgsMessageLog.logMessage(f"live preview: {result['message']}", "fotogeo picker", Qgis.Warning)

    def _action_row(self) -> QWidget:
        stack = self.controller.undo_stack
        self.undo_button, self.redo_button = QPushButton("Undo"), QPushButton("Redo")
        self.undo_button.clicked.connect(stack.undo)
        self.redo_button.clicked.connect(stack.redo)
        stack.canUndoChanged.connect(self.undo_button.setEnabled)
        stack.canRedoChanged.connect(self.redo_button.setEnabled)
        self.undo_button.setEnabled(False)
        self.redo_button.setEnabled(False)
        for action, keys in ((stack.createUndoAction(self), QKeySequence.StandardKey.Undo),
                             (stack.createRedoAction(self), QKeySequence.StandardKey.Redo)):
            action.setShortcut(keys)  # Ctrl+Z / Ctrl+Shift+Z while the dock has the focus
            action.setShortcutContext(Qt.ShortcutContext.WidgetWithChildrenShortcut)
            self.addAction(action)
        widgets = [self.undo_button, self.redo_button]
        for text, slot in (("Import…", self.import_dialog), ("Export…", self.export_dialog),
                           ("Rectify…", lambda: self.run_dialog("rectify")), ("RPC…", lambda: self.run_dialog("rpc")),
                           ("Report…", lambda: self.run_dialog("report")), ("Pick on map", self.activate_map_tool)):
            b = QPushButton(text)
            b.clicked.connect(slot)
            widgets.append(b)
        return _row(*widgets)

    # -- state --------------------------------------------------------------------------------
    def fit_settings(self) -> FitSettings:
        dem = self.dem_combo.currentLayer()
        camera = self.camera_file.filePath() or None
        return FitSettings(model=self.model_combo.currentText(), height_source=self.height_combo.currentText(),
                           dem=dem.source() if dem is not None else None, height=self.height_spin.value(),
                           camera=camera, image_sigma=self.sigma_spin.value() or None)

    def _image_path_typed(self):
        path = self.image_file.filePath()
        if path and not os.path.isfile(path):
            self.say(f"image {path!r} does not exist; choose an image file (… button) or a raster layer")

    def open_image(self, path: str) -> bool:
        """Show ``path`` on the image canvas in pixel units; False (and the reason shown) if it cannot."""
        try:
            image = PickerImage(path, on_overviews=lambda ok, error: self.say(
                "pyramids built" if ok else f"pyramids not built: {error}"))
        except ImageError as e:
            self.say(str(e))
            return False
        old, self.image = self.image, image
        self.image_file.blockSignals(True)
        self.image_file.setFilePath(path)
        self.image_file.blockSignals(False)
        self.image_canvas.setDestinationCrs(image.layer.crs())
        self.image_canvas.setLayers([image.layer])
        self.image_canvas.setExtent(image.layer.extent())
        self.image_canvas.refresh()
        self.controller.set_image(image)
        if old is not None:
            old.close()
        return True

    def new_gcp_layer(self, crs: QgsCoordinateReferenceSystem | None = None, path: str | None = None) -> GcpLayer:
        """A new GCP layer in ``crs`` (default: the map canvas's CRS), added to the project and chosen: a
        GeoPackage at ``path`` (its points are kept in the file), else a memory layer."""
        crs = crs or self.map_canvas.mapSettings().destinationCrs()
        names = {layer.name() for layer in QgsProject.instance().mapLayers().values()}
        name = next(n for n in ("fotogeo GCPs", *(f"fotogeo GCPs {k}" for k in range(2, 10000))) if n not in names)
        store = GcpLayer.create_gpkg(path, crs, name) if path else GcpLayer.create(crs, name)
        self.gcp_combo.setLayer(store.layer)
        return store

    def _gcp_layer_chosen(self, layer):
        if layer is None:
            self.controller.set_store(None)
            return
        try:
            self.controller.set_store(GcpLayer(layer))
        except ValueError as e:
            self.say(str(e))
            self.controller.set_store(None)

    def _exaggeration_changed(self, value):
        self.controller.exaggeration = value
        self.controller.show()

    def delete_gcps(self, ids: list):
        """Delete the GCPs ``ids`` (the table's selected rows, in any sort order) as one undo step; taken in the
        layer's order, so that an undo adds them back in it."""
        store = self.controller.store
        found = [g for g in store.gcps() if g.id in set(ids)] if store is not None else []
        if store is not None and found:
            self.controller.undo_stack.push(DeleteGcps(store, found))

    def _show_fit(self, fit: dict):
        store = self.controller.store
        self.table.fill(store.gcps() if store else [], fit)
        self.summary.setText(self.describe_fit(fit))
        self.update_preview()

    def activate_map_tool(self):
        self.map_canvas.setMapTool(self.tools[MAP])

    def showEvent(self, event):  # noqa: N802 - Qt's name
        """Shown again after a close: the marks come back and the map tool picks again."""
        for overlay in self.controller.overlays.values():
            overlay.setVisible(True)
        self.preview.set_visible(True)
        self.activate_map_tool()
        self.update_preview()  # none was computed while the dock was closed
        super().showEvent(event)
        if not getattr(self, "_split", False):  # the first show, laid out: the split by the shares, not the minima
            self._split = True
            QTimer.singleShot(200, self._share_split)  # after the main window has sized the dock

    def _share_split(self):
        total = sum(self.splitter.sizes())
        self.splitter.setSizes([total * IMAGE_SHARE // (IMAGE_SHARE + TABLE_SHARE),
                                total * TABLE_SHARE // (IMAGE_SHARE + TABLE_SHARE)])

    def closeEvent(self, event):  # noqa: N802 - Qt's name
        """Closed (the dock's X): the main canvas gets its tool back, the marks are hidden, the state kept."""
        self._release_tools()
        for overlay in self.controller.overlays.values():
            overlay.setVisible(False)
        self.preview.set_visible(False)
        super().closeEvent(event)

    def _release_tools(self):
        for tool in self.tools.values():
            if tool.canvas().mapTool() is tool:
                tool.canvas().unsetMapTool(tool)

    def close_picker(self):
        """The plugin's unload: release the map tools and remove the marks for good."""
        self._release_tools()
        self.controller.close()
        self.map_canvas.extentsChanged.disconnect(self.update_preview)
        self.preview.close()
        if self.image is not None:
            self.image_canvas.setLayers([])
            self.image.close()
            self.image = None
