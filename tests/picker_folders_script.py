"""The live preview's temporary folder (run by tests/test_qgis_picker_preview.py as ``python picker_folders_script.py
ARGS.json``): none before the first warp, one after it, and none left when the process ends without closing the
preview (a QGIS killed, a dock never closed) — nor after the plugin's unload. Writes ``ARGS["out"]/state.json``
and ends with an ordinary interpreter exit (``ARGS["unload"]``: after the unload's clean-up, then ``os._exit``)."""
from __future__ import annotations

import json
import os
import sys

ARGS = json.loads(open(sys.argv[1]).read())
sys.path.insert(0, ARGS["root"])
from qgis.core import QgsApplication  # noqa: E402

APP = QgsApplication([], True)
APP.initQgis()
from qgis.gui import QgsMapCanvas  # noqa: E402

from processing_provider.picker import preview  # noqa: E402


class NoWarp:
    """A stand-in for the preview's worker session: answers without warping."""

    def call(self, *args, **kwargs):
        return {"ok": False, "message": "no warp here"}

    def close(self):
        pass


canvas = QgsMapCanvas()
live = preview.LivePreview(canvas, NoWarp())
state = {"before_first_warp": live.folder}
live.request({"model": "affine"})
state["after_first_warp"] = live.folder and os.path.isdir(live.folder)
if ARGS.get("unload"):
    from processing_provider.plugin import FotogeoPlugin  # noqa: E402
    FotogeoPlugin().unload()  # never loaded: only what unload does beyond the plugin's own parts
    state["after_unload"] = os.path.isdir(live.folder)
with open(os.path.join(ARGS["out"], "state.json"), "w") as f:
    json.dump(state, f)
sys.stdout.flush()
if ARGS.get("unload"):
    os._exit(0)  # no interpreter exit: only the unload removed it
