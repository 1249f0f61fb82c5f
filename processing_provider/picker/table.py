"""The picker's GCP table: one row per GCP with its residuals in pixels and map units.

Columns: id, *on* (the Georeferencer's *enable*: ticked = used, unticked = disabled, ignored by
the fit and the RMS though its residual is still shown), *role* (``control`` fits the model,
``check`` measures it; double-click to choose), col, row (px, corner convention), x, y (layer CRS), z and where it came from (field, DEM,
constant), dx, dy, residual in px and in map units (model minus measurement, the same numbers
``fotogeo orient`` reports), the standardised residual w of data snooping (Baarda 1968) and the
flag (blunder, no height, ...). Selecting a row highlights the GCP on both canvases; the z cell can
be edited (a number, or empty for none): the layer's height, used with *Heights: field*. The Delete
key asks to delete the selected rows (``delete_requested``: one undo step for all of them).

A click on a header sorts by that column (numbers as numbers, empty cells below the others when
descending; a second click reverses). Every cell carries its GCP's id, so selection, edits and
Delete act on the point shown in the row whatever the order; a refill after a refit keeps the
sort and re-selects the same GCPs (not the same row numbers).
"""
from __future__ import annotations

from qgis.PyQt.QtCore import QItemSelection, QItemSelectionModel, Qt, pyqtSignal
from qgis.PyQt.QtGui import QColor, QKeySequence
from qgis.PyQt.QtWidgets import QAbstractItemView, QComboBox, QStyledItemDelegate, QTableWidget, QTableWidgetItem

from .fit import alarming

#: rows the table shows without scrolling at its minimum height
MIN_ROWS = 6
SORT_KEY = Qt.ItemDataRole.UserRole + 1

#: what a user reads first (residual, w, flag) next to the id, without scrolling; coordinates after
COLUMNS = ("id", "on", "role", "res px", "w", "flag", "dx px", "dy px", "res map", "dx map", "dy map", "col", "row", "x", "y",
           "z", "z from")
#: header tooltips: what each column means, "on" against the Georeferencer's "enable"
TOOLTIPS = {
    "on": "Ticked: the point is used (as its role says). Unticked: disabled, ignored by the fit and the RMS, as the "
          "Georeferencer's unticked 'enable' (its residual to the model is still shown)",
    "role": "control: fits the model. check: left out of the fit and measured against it (check RMS). "
            "Double-click to change",
    "w": "Standardised residual (data snooping); empty where the redundancy cannot test the point",
    "flag": "blunder: |w| above the critical value for this redundancy; not testable: too little redundancy",
    "res px": "Residual in image pixels (model − measured)", "res map": "Residual on the ground, map units",
    "z from": "Where the height comes from: field, dem, constant or none"}
#: table column -> (key in fit_gcps' point rows, decimals)
RESULT_COLUMNS = {"dx px": ("dx_px", 3), "dy px": ("dy_px", 3), "res px": ("residual_px", 3),
                  "dx map": ("dx_map", 3), "dy map": ("dy_map", 3), "res map": ("residual_map", 3), "w": ("w", 2)}


def _text(value, decimals: int) -> str:
    return "" if value is None else f"{value:.{decimals}f}"


ROLE_CHOICES = ("control", "check")


def sort_key(text: str):
    """A cell's sort key: ``(0, number)`` for numbers (ids "2" before "10"), ``(1, text)`` for words, and
    ``(-1, 0)`` for an empty cell, so that sorting descending puts the largest numbers first and empties last."""
    if not text:
        return (-1, 0.0)
    try:
        return (0, float(text))
    except ValueError:
        return (1, text.lower())


class GcpItem(QTableWidgetItem):
    """A cell that sorts by :func:`sort_key` of its text (the *on* cell by its check state)."""

    def __lt__(self, other):
        return self.data(SORT_KEY) < other.data(SORT_KEY)


class RoleDelegate(QStyledItemDelegate):
    """The role cell's editor: a combo box of :data:`ROLE_CHOICES`."""

    def createEditor(self, parent, option, index):  # noqa: N802 - Qt's name
        combo = QComboBox(parent)
        combo.addItems(ROLE_CHOICES)
        return combo

    def setEditorData(self, editor, index):  # noqa: N802 - Qt's name
        editor.setCurrentText(index.data())

    def setModelData(self, editor, model, index):  # noqa: N802 - Qt's name
        model.setData(index, editor.currentText())


class GcpTable(QTableWidget):
    """The table (module docstring); ``enabled_changed(id, on)``, ``role_changed(id, role)``, ``height_changed(id, z)``,
    ``gcp_selected(id)`` and ``delete_requested([id, ...])`` go to the controller."""

    enabled_changed = pyqtSignal(str, bool)
    role_changed = pyqtSignal(str, str)
    height_changed = pyqtSignal(str, object)  # id, float or None
    gcp_selected = pyqtSignal(str)
    delete_requested = pyqtSignal(list)  # ids of the selected rows, in table order

    def __init__(self, parent=None):
        super().__init__(0, len(COLUMNS), parent)
        self.setHorizontalHeaderLabels(COLUMNS)
        for j, name in enumerate(COLUMNS):
            if name in TOOLTIPS:
                self.horizontalHeaderItem(j).setToolTip(TOOLTIPS[name])
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setSelectionMode(QAbstractItemView.SelectionMode.ExtendedSelection)
        self.setEditTriggers(QAbstractItemView.EditTrigger.DoubleClicked | QAbstractItemView.EditTrigger.EditKeyPressed)
        self.verticalHeader().setVisible(False)
        row_height = self.fontMetrics().height() + 6  # compact rows, as the Georeferencer's table
        self.verticalHeader().setDefaultSectionSize(row_height)
        self.setMinimumHeight(MIN_ROWS * row_height + self.horizontalHeader().sizeHint().height()
                              + self.horizontalScrollBar().sizeHint().height() + 2 * self.frameWidth())
        self.setSortingEnabled(True)
        self.sortByColumn(COLUMNS.index("id"), Qt.SortOrder.AscendingOrder)
        self.role_delegate = RoleDelegate(self)
        self.setItemDelegateForColumn(COLUMNS.index("role"), self.role_delegate)
        self._filling = False
        self.itemChanged.connect(self._item_changed)
        self.itemSelectionChanged.connect(self._selection_changed)

    def fill(self, gcps, fit: dict) -> None:
        """Show ``gcps`` (:class:`~.gcp_layer.Gcp`) with the rows of ``fit`` (``fit_gcps``'s result), in the current
        sort order, the same GCPs selected as before."""
        rows = {p["id"]: p for p in fit.get("points", [])}
        selected = set(self.selected_ids())
        self._filling = True
        self.setSortingEnabled(False)  # rows placed where written; sorted once at the end
        try:
            self.setRowCount(len(gcps))
            for i, g in enumerate(gcps):
                for j, item in enumerate(self._items(g, rows.get(g.id, {}))):
                    self.setItem(i, j, item)
            self.setSortingEnabled(True)
            self._select(selected)
        finally:
            self._filling = False
        self.resizeColumnsToContents()

    @staticmethod
    def _items(g, r: dict) -> list:
        """The cells of GCP ``g`` with its fit row ``r``."""
        values = {"id": g.id, "col": _text(g.col, 2), "row": _text(g.row, 2), "x": _text(g.x, 3),
                  "y": _text(g.y, 3), "z": _text(r.get("z", g.z), 2), "z from": r.get("z_source", ""),
                  "flag": r.get("flag", ""), "role": g.role}
        values.update({c: _text(r.get(k), d) for c, (k, d) in RESULT_COLUMNS.items()})
        items = []
        for name in COLUMNS:
            item = GcpItem("" if name == "on" else str(values.get(name, "")))
            item.setData(Qt.ItemDataRole.UserRole, g.id)
            item.setData(SORT_KEY, (0, float(g.enabled)) if name == "on" else sort_key(item.text()))
            if name == "on":
                item.setFlags(Qt.ItemFlag.ItemIsUserCheckable | Qt.ItemFlag.ItemIsEnabled | Qt.ItemFlag.ItemIsSelectable)
                item.setCheckState(Qt.CheckState.Checked if g.enabled else Qt.CheckState.Unchecked)
            else:
                editable = Qt.ItemFlag.ItemIsEditable if name in ("z", "role") else Qt.ItemFlag.NoItemFlags
                item.setFlags(Qt.ItemFlag.ItemIsEnabled | Qt.ItemFlag.ItemIsSelectable | editable)
            if not g.enabled and name != "on":
                item.setForeground(QColor(140, 140, 140))  # disabled: greyed, as its marks
            if name not in ("id", "on", "role"):
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            if alarming(r.get("flag")):  # a blunder, a suspect, no height: orange; "not testable" stays plain
                item.setBackground(QColor(255, 220, 160))
            items.append(item)
        return items

    def _select(self, ids: set) -> None:
        """Select the rows of the GCPs ``ids`` (wherever the sort put them), nothing else."""
        selection = QItemSelection()
        for r in range(self.rowCount()):
            if self.item(r, 0) is not None and self.item(r, 0).data(Qt.ItemDataRole.UserRole) in ids:
                selection.select(self.model().index(r, 0), self.model().index(r, len(COLUMNS) - 1))
        self.selectionModel().select(selection, QItemSelectionModel.SelectionFlag.ClearAndSelect)

    def row_values(self, row: int) -> dict:
        """The texts of one row by column name (tests and the report)."""
        return {name: self.item(row, j).text() if name != "on" else self.item(row, j).checkState() == Qt.CheckState.Checked
                for j, name in enumerate(COLUMNS)}

    def selected_ids(self) -> list[str]:
        """Ids of the selected rows, in table order."""
        rows = sorted({index.row() for index in self.selectedIndexes()})
        return [self.item(r, 0).data(Qt.ItemDataRole.UserRole) for r in rows if self.item(r, 0) is not None]

    def keyPressEvent(self, event):  # noqa: N802 - Qt's name
        """Delete (the platform's delete key sequence too) deletes the selected rows; other keys as usual.

        While a cell is being edited the key goes to the editor, not here."""
        ids = self.selected_ids()
        if ids and (event.key() == Qt.Key.Key_Delete or event.matches(QKeySequence.StandardKey.Delete)):
            self.delete_requested.emit(ids)
            event.accept()
            return
        super().keyPressEvent(event)

    def _item_changed(self, item):
        if self._filling:
            return
        column, gcp_id = COLUMNS[item.column()], item.data(Qt.ItemDataRole.UserRole)
        if column == "on":
            self.enabled_changed.emit(gcp_id, item.checkState() == Qt.CheckState.Checked)
        elif column == "role":
            role = item.text().strip().lower()
            if role in ROLE_CHOICES:
                self.role_changed.emit(gcp_id, role)
        elif column == "z":
            text = item.text().strip().replace(",", ".")
            try:
                self.height_changed.emit(gcp_id, float(text) if text else None)
            except ValueError:
                item.setText("")  # not a number: no height

    def _selection_changed(self):
        if self._filling:
            return
        items = self.selectedItems()
        if items:
            self.gcp_selected.emit(items[0].data(Qt.ItemDataRole.UserRole))
