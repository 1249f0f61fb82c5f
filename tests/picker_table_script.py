"""The picker's table sorted by clicks on its header, driven by simulated input in a GUI QgsApplication (offscreen);
run by tests/test_qgis_picker_table.py as ``python picker_table_script.py ARGS.json``.

Ten GCPs of the NGI frame (affine), GCP 5 clicked 12 screen px off on the map. The header clicked: by id
descending then ascending (2 before 10), then by residual until descending; a refit with another model (the
order changes, the selected GCP stays selected); the top row clicked and deleted with the Delete key, undone,
redone; a role set in the top row; the table's geometry in the dock. Writes ``ARGS["out"]/state.json``.
"""
from __future__ import annotations

import picker_gui_script as base  # noqa: E402 - its QgsApplication, setup and pump
from picker_driver import fitted, frame_dock, gcps, pick, run, settle, sort_by, table  # noqa: E402
from qgis.PyQt.QtCore import QEvent, Qt  # noqa: E402
from qgis.PyQt.QtGui import QKeyEvent  # noqa: E402
from qgis.PyQt.QtTest import QTest  # noqa: E402

from processing_provider.picker.table import COLUMNS, MIN_ROWS  # noqa: E402

ARGS, STATE, pump = base.ARGS, base.STATE, base.pump


def click_row(t, row: int):
    rect = t.visualRect(t.model().index(row, 0))
    QTest.mouseClick(t.viewport(), Qt.LeftButton, Qt.NoModifier, rect.center())
    pump(0.1)


def column(dock, name: str) -> list:
    return [row[name] for row in table(dock)]


def main():
    canvas, dock = frame_dock(base.setup, ARGS, "affine")
    truth = ARGS["gcps"]
    off = 12 * canvas.mapUnitsPerPixel()
    for k in range(10):
        pick(dock, {**truth[k], "x": truth[k]["x"] + off} if k == 4 else truth[k])
    t = dock.table
    STATE["geometry"] = {"table_height": t.height(), "row_height": t.rowHeight(0), "min_rows": MIN_ROWS,
                         "canvas_height": dock.image_canvas.height(), "dock_height": dock.height(),
                         "visible_rows": t.viewport().height() / t.rowHeight(0)}
    STATE["by_id"] = {"ids": [sort_by(t, "id", Qt.DescendingOrder) and column(dock, "id"),
                              sort_by(t, "id", Qt.AscendingOrder) and column(dock, "id")]}
    sort_by(t, "res px", Qt.DescendingOrder)
    fit = fitted(dock)
    STATE["by_residual"] = {"ids": column(dock, "id"), "res": column(dock, "res px"), "fit": fit["points"]}
    selected_and_refit(dock, t)
    delete_top_row(dock, t)
    role_in_top_row(dock, t)


def selected_and_refit(dock, t):
    """The third row selected by a click, then the projective model: residuals and order change, the GCP stays."""
    click_row(t, 2)
    chosen = t.selected_ids()
    dock.model_combo.setCurrentText("projective")
    ids = column(dock, "id")
    STATE["refit"] = {"chosen": chosen, "controller": dock.controller.selected,
                      "ids_before": STATE["by_residual"]["ids"],
                      "ids_after": ids, "res_after": column(dock, "res px"), "selected_after": t.selected_ids(),
                      "selected_rows": sorted({i.row() for i in t.selectedIndexes()})}
    dock.model_combo.setCurrentText("affine")
    settle(dock)


def delete_top_row(dock, t):
    click_row(t, 0)
    top = t.selected_ids()
    largest = max(fitted(dock)["points"], key=lambda p: p["residual_px"])["id"]
    before = gcps(dock)
    base.APP.sendEvent(t, QKeyEvent(QEvent.KeyPress, Qt.Key_Delete, Qt.NoModifier))
    deleted = gcps(dock)
    STATE["delete"] = {"top": top, "largest": largest, "before": [g["id"] for g in before],
                       "after": [g["id"] for g in deleted], "table_after": column(dock, "id"),
                       "res_after": column(dock, "res px")}
    stack = dock.controller.undo_stack
    stack.undo()
    STATE["delete"]["undone"] = [g["id"] for g in gcps(dock)]
    stack.redo()
    STATE["delete"]["redone"] = [g["id"] for g in gcps(dock)]
    stack.undo()
    settle(dock)


def role_in_top_row(dock, t):
    top = t.item(0, 0).text()
    t.item(0, COLUMNS.index("role")).setText("check")
    STATE["role"] = {"top": top, "roles": {g["id"]: g["role"] for g in gcps(dock)}}
    dock.controller.undo_stack.undo()
    STATE["role"]["undone"] = {g["id"]: g["role"] for g in gcps(dock)}


if __name__ == "__main__":
    run(main, STATE, ARGS["out"])
