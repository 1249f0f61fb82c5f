"""The picker's click precision (``Click σ``) reaches the blunder test, in a GUI QgsApplication (offscreen); run by
tests/test_qgis_picker_sigma.py as ``python picker_sigma_script.py ARGS.json``.

GCPs of the NGI frame (DLT, heights from the DEM) given to the dock's controller with the test's noisy pixels: the
flags at σ = 1 px, at 10 px and with σ estimated; eight clean GCPs at 1 px; orient's arguments for Rectify/Report.
Writes ``ARGS["out"]/state.json``.
"""
from __future__ import annotations

import picker_gui_script as base  # noqa: E402 - its QgsApplication, setup and pump
from picker_driver import fitted, frame_dock, run  # noqa: E402
from qgis.core import QgsProject, QgsRasterLayer  # noqa: E402

from processing_provider.picker.gcp_layer import Gcp  # noqa: E402

ARGS, STATE = base.ARGS, base.STATE


def flags(dock) -> dict:
    fit = fitted(dock)
    return {"ok": fit.get("ok"), "flags": {p["id"]: p.get("flag") for p in fit["points"] if p.get("flag")},
            "w": {p["id"]: p.get("w") for p in fit["points"]}, "summary": dock.summary.text()}


def put(dock, points):
    store = dock.controller.store
    old = store.gcps()
    if old:
        from processing_provider.picker.commands import DeleteGcps
        dock.controller.undo_stack.push(DeleteGcps(store, old))
    dock.controller.add([Gcp(str(k + 1), p["col"], p["row"], p["x"], p["y"]) for k, p in enumerate(points)], "test")


def main():
    canvas, dock = frame_dock(base.setup, ARGS, "dlt")
    dem = QgsRasterLayer(ARGS["dem"], "dem")
    QgsProject.instance().addMapLayer(dem, False)
    dock.height_combo.setCurrentText("dem")
    dock.dem_combo.setLayer(dem)
    STATE["default_sigma"] = dock.sigma_spin.value()
    put(dock, ARGS["noisy"])
    for sigma in (1.0, 10.0, 0.0):
        dock.sigma_spin.setValue(sigma)
        STATE[f"sigma_{sigma:g}"] = flags(dock)
        STATE[f"sigma_{sigma:g}"]["orange_marks"] = [m.label for m in dock.controller._marks("map") if m.flagged]
    dock.sigma_spin.setValue(1.0)
    STATE["orient_sigma"] = dock.orient_arguments().get("image_sigma")
    put(dock, ARGS["clean"])
    STATE["clean"] = flags(dock)


if __name__ == "__main__":
    run(main, STATE, ARGS["out"])
