"""fotogeo:triangulate in headless QGIS on a block with an undetermined frame and on one without ground control:
the dropped frame is a warning in the log in the dialog's words (first among the summary lines), and a block
without control or check points loads no empty "Control and check points" table (a drone flight on its GPS: it
loaded a layer without geometry, and QGIS reported it in red as "not correctly generated"); the log says the
block's map CRS and why, as the command line does; an RGB orthophoto's node is collapsed (its Band 1/2/3 legend,
expanded on every other orthophoto of the eBee block, only lengthened the layer list)."""
from __future__ import annotations

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingContext, QgsProject  # noqa: E402

from fotogeo.options import TRIANGULATE  # noqa: E402
from test_qgis_provider import Recorder  # noqa: E402
from test_triangulate import write_block  # noqa: E402
from test_triangulate_drop_default import _slivers, sb  # noqa: E402,F401 - sb: a fixture


class Log(Recorder):
    """Records the log's lines as (kind, text)."""

    def __init__(self):
        super().__init__()
        self.lines = []

    def pushInfo(self, info):
        self.lines.append(("info", info))
        super().pushInfo(info)

    def pushWarning(self, warning):
        self.lines.append(("warning", warning))
        super().pushWarning(warning)


def _run(params):
    import processing
    project = QgsProject.instance()
    project.removeAllMapLayers()
    context = QgsProcessingContext()
    context.setProject(project)
    log = Log()
    processing.runAndLoadResults("fotogeo:triangulate", params, feedback=log, context=context)
    return log, [n.name() for n in project.layerTreeRoot().findLayers()]


def test_a_dropped_frame_is_the_first_warning_in_the_dialogs_words(qgis_app, sb, tmp_path):  # noqa: F811
    name = sb.block.frames[4]
    frames, checks = write_block(tmp_path, _slivers(sb, [4]))
    log, layers = _run({"FRAMES": [str(f) for f in frames], "CAMERA": str(tmp_path / "camera.yaml"),
                        "EO": str(tmp_path / "eo.txt"), "OBSERVATIONS": str(tmp_path / "tie.csv"),
                        "GCPS": str(tmp_path / "gcp_list.txt"), "CHECK_POINTS": checks, "IMAGE_SIGMA": 0.3,
                        "OUTDIR": str(tmp_path / "out")})
    summary = log.lines[[text for _, text in log.lines].index(next(t for _, t in log.lines if "frames dropped" in t)):]
    kind, first = summary[0]
    assert kind == "warning" and first.startswith(f"1 of 10 frames dropped (undetermined): {name} — "), log.lines
    assert first.endswith(f"; “{TRIANGULATE['undetermined'].label}” fail stops the run instead"), first
    assert "--undetermined" not in first
    assert summary[1][1].startswith("9 frames, ")  # the statistics come after it
    assert summary[2][1].startswith("σ of the results: covariances scaled by "), summary  # as the CLI says
    assert "Control and check points" in layers


def test_a_block_without_control_loads_no_empty_control_layer(qgis_app, sb, tmp_path):  # noqa: F811
    frames, _ = write_block(tmp_path, sb)
    log, layers = _run({"FRAMES": [str(f) for f in frames], "CAMERA": str(tmp_path / "camera.yaml"),
                        "EO": str(tmp_path / "eo.txt"), "OBSERVATIONS": str(tmp_path / "tie.csv"),
                        "EO_SIGMA_POSITION": 10.0, "EO_SIGMA_ANGLE": 2.0, "CRS": "EPSG:32635",
                        "OUTDIR": str(tmp_path / "out")})
    assert "Tie points" in layers and "Frame footprints" in layers
    assert "Control and check points" not in layers, layers
    # the block's CRS and why, in the dialog's words (a drone flight gives none: the log must say which)
    assert ("info", "map CRS EPSG:32635: given (“Map CRS of the block (empty = from the GCPs, orthophotos, DEM or "
                    "GPS)”)") in log.lines, log.lines
    assert not log.errors, log.errors


def test_an_rgb_orthophoto_loads_collapsed(qgis_app, tmp_path):  # noqa: F811
    import numpy as np
    import rasterio
    from qgis.core import QgsRasterLayer

    from processing_provider.postprocess import StylePostProcessor
    path = tmp_path / "IMG_1_ortho.tif"
    with rasterio.open(path, "w", driver="GTiff", width=64, height=48, count=3, dtype="uint8", crs="EPSG:32654",
                       transform=rasterio.transform.from_origin(500000, 4150000, 0.03, 0.03)) as ds:
        ds.write(np.random.default_rng(0).integers(0, 255, (3, 48, 64), dtype=np.uint8))
    project = QgsProject.instance()
    project.removeAllMapLayers()
    layer = QgsRasterLayer(str(path), "IMG_1 ortho")
    assert layer.isValid() and layer.renderer().type() == "multibandcolor"
    project.addMapLayer(layer)
    node = project.layerTreeRoot().findLayer(layer.id())
    node.setExpanded(True)
    StylePostProcessor(None).postProcessLayer(layer, None, None)
    assert not node.isExpanded()
