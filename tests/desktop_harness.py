"""Shared by the startup scripts (``qgis --code``) of the desktop tests (test_qgis_real_programs.py,
test_qgis_picker_desktop.py): a result dict written to ``<out>/result.json`` when the script finishes or
one of its steps fails (then with the traceback under ``"error"``), QGIS quit afterwards, and screenshots.
"""
import json
import os
import traceback

from qgis.core import QgsApplication
from qgis.PyQt.QtCore import Qt


class Harness:
    def __init__(self, out: str):
        self.out, self.state = out, {}

    def finish(self):
        with open(os.path.join(self.out, "result.json"), "w") as f:
            json.dump(self.state, f)
        QgsApplication.exit(0)

    def guard(self, fn):
        """``fn`` wrapped so that an exception ends the run with its traceback in the result."""
        def wrapped(*args):
            try:
                fn(*args)
            except Exception:
                self.state["error"] = traceback.format_exc()
                self.finish()
        return wrapped

    def grab(self, widget, name, width=None):
        """Save ``widget`` as ``<out>/<name>`` (PNG), scaled to ``width`` pixels when given."""
        image = widget.grab()
        if width:
            image = image.scaledToWidth(width, Qt.SmoothTransformation)
        image.save(os.path.join(self.out, name), "PNG", 9)
