"""The surface model as a QGIS user sees it: ``fotogeo:dsm`` (and triangulate's "Surface model (DSM)") load the
DSM as band 1, the height, in pseudocolour over its 2 … 98 % cumulative cut — not as a false-colour RGB of height,
pair count and spread — named after its file; and ``qgis_process help`` prints the algorithms' help as plain text
(the desktop dialog renders its HTML)."""
from __future__ import annotations

import numpy as np
import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()


def _write_dsm(path):
    """A 3-band DSM as ``fotogeo dsm`` writes it (height, pairs, spread; nodata -32767) whose heights run 100 … 200 m
    with a few blunders at 5000 m and a hole; returns the heights written."""
    import rasterio
    from affine import Affine
    height = np.linspace(100.0, 200.0, 40 * 50, dtype=np.float32).reshape(40, 50)
    height[0, :6] = 5000.0
    height[-1, -4:] = -32767.0
    pairs = np.indices(height.shape).sum(axis=0) % 3 + 1.0
    bands = np.stack([height, np.where(height > -32767, pairs, -32767), np.where(height > -32767, pairs / 4, -32767)])
    with rasterio.open(path, "w", driver="GTiff", width=50, height=40, count=3, dtype="float32", crs="EPSG:32735",
                       transform=Affine(2, 0, 500000, 0, -2, 7000000), nodata=-32767) as ds:
        ds.write(bands.astype(np.float32))
        for k, name in enumerate(("height", "pairs", "spread")):
            ds.set_band_description(k + 1, name)
    return height[height > -32767]


def _loaded(context, path):
    """The layer Processing would load for ``path`` on completion: its name and post-processor as the algorithm
    left them, the post-processor run on it (and the layer tree's legend told of its new renderer)."""
    from qgis.core import QgsProcessingFeedback, QgsRasterLayer
    details = context.layerToLoadOnCompletionDetails(path)
    layer = QgsRasterLayer(path, details.name)
    context.project().addMapLayer(layer)
    assert details.postProcessor() is not None, "no style set on the DSM"
    told = []
    layer.rendererChanged.connect(lambda: told.append(True))
    details.postProcessor().postProcessLayer(layer, context, QgsProcessingFeedback())
    assert told, "the legend was not told of the new range (it would label the ramp 0 m … 1 m)"
    return details, layer


def _context(path, description):
    """A Processing context that loads the destination ``path`` on completion, as the dialog's "Open output file
    after running algorithm" does (named after the parameter's ``description``); and its project (a context does
    not keep it alive)."""
    from qgis.core import QgsProcessingContext, QgsProcessingUtils, QgsProject
    context = QgsProcessingContext()
    project = QgsProject()
    context.setProject(project)
    context.addLayerToLoadOnCompletion(path, QgsProcessingContext.LayerDetails(
        description, project, "OUTPUT", QgsProcessingUtils.LayerHint.Raster))
    return context, project


def _assert_height_in_pseudocolour(layer, heights):
    renderer = layer.renderer()
    assert renderer.type() == "singlebandpseudocolor" and renderer.band() == 1
    lo, hi = renderer.classificationMin(), renderer.classificationMax()
    # over the heights' 2 … 98 % (a histogram's bins apart), not flattened by the blunders at 5000 m
    assert abs(lo - np.quantile(heights, 0.02)) < 3 and abs(hi - np.quantile(heights, 0.98)) < 3, (lo, hi)
    ramp = renderer.shader().rasterShaderFunction()
    assert ramp.legendSettings().suffix() == " m"
    assert ramp.colorRampItemList()[0].value == pytest.approx(lo)


def test_the_dsm_loads_as_its_height_in_pseudocolour_named_after_its_file(qgis_app, tmp_path):
    from qgis.core import QgsApplication, QgsProcessingFeedback
    alg = QgsApplication.processingRegistry().createAlgorithmById("fotogeo:dsm")
    output = str(tmp_path / "block_dsm.tif")
    context, _project = _context(output, "Surface model (DSM)")
    written = {}

    def run_tool(tool, images, out, **kwargs):  # the worker's part: the DSM file and its report
        written["heights"] = _write_dsm(out)
        return {"pairs": [], "completeness": 0.9}
    alg.run_tool = run_tool
    images = [str(tmp_path / "a.tif"), str(tmp_path / "b.tif")]
    for image in images:  # taken as they are: the fake worker does not read them
        _write_dsm(image)
    result = alg.processAlgorithm({"IMAGES": images, "OUTPUT": output}, context, QgsProcessingFeedback())
    assert result["OUTPUT"] == output
    details, layer = _loaded(context, output)
    assert details.name == "block_dsm" and details.forceName and layer.name() == "block_dsm"
    _assert_height_in_pseudocolour(layer, written["heights"])


def test_triangulate_shows_its_dsm_as_fotogeo_dsm_does(qgis_app, tmp_path):
    from qgis.core import QgsApplication
    alg = QgsApplication.processingRegistry().createAlgorithmById("fotogeo:triangulate")
    output = str(tmp_path / "surface.tif")
    heights = _write_dsm(output)
    context, _project = _context(output, "Surface model (DSM) of the adjusted frames")
    reported = str(tmp_path / "." / "surface.tif")  # the tool's spelling of the path Processing holds
    rep = {"sigma0": 1.0, "statistics": {"check": {}, "image_rms_px": 0.5, "n_blunders": 0},
           "dsm": {"outputs": {"dsm": reported}}}
    assert alg._outputs(rep, str(tmp_path), context)["DSM"] == reported
    details, layer = _loaded(context, output)
    assert details.name == "surface" and layer.name() == "surface"
    _assert_height_in_pseudocolour(layer, heights)


def test_qgis_process_prints_the_help_as_plain_text(qgis_app, monkeypatch):
    """``qgis_process help`` prints shortHelpString as it is: there, no tags and no entities."""
    from qgis.core import QgsApplication

    from processing_provider.algorithms import base

    class QgisProcess:
        @staticmethod
        def platform():
            return "qgis_process"
    reg = QgsApplication.processingRegistry()
    desktop = reg.algorithmById("fotogeo:ortho").shortHelpString()
    assert "<b>Occlusion masking</b>" in desktop  # the dialog renders it
    monkeypatch.setattr(base, "QgsApplication", QgisProcess)
    for alg in reg.providerById("fotogeo").algorithms():
        text = alg.shortHelpString()
        assert "<b>" not in text and "&lt;" not in text and "&gt;" not in text, alg.id()
    text = reg.algorithmById("fotogeo:ortho").shortHelpString()
    assert "Occlusion masking (with a DSM" in text and "<name>_ortho_sigma.tif" in text
    assert "satellite images carrying an RPC" in reg.algorithmById("fotogeo:dsm").shortHelpString()


def test_the_command_lines_dsm_opens_in_qgis_as_its_height(qgis_app, tmp_path):
    """``fotogeo dsm -o dsm.tif`` opened in QGIS without the plugin (browser, drag and drop, Layer > Add raster:
    a QgsRasterLayer with its default style) is drawn as band 1 in pseudocolour over its heights' 2 … 98 %, as the
    plugin loads it; the same file without its ``dsm.qml`` is QGIS's RGB of height, pairs and spread."""
    import shutil
    import subprocess
    import sys

    from qgis.core import QgsRasterLayer
    from rendered_pair import render
    (tmp_path / "pair").mkdir()
    pair = render(tmp_path / "pair", 256)
    out = tmp_path / "dsm.tif"
    r = subprocess.run([sys.executable, "-m", "fotogeo", "dsm", *map(str, pair["images"]), "--camera",
                        str(pair["camera"]), "--eo", str(pair["eo"]), "--crs", "EPSG:32635", "-o", str(out)],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    bare = tmp_path / "bare" / "dsm.tif"
    bare.parent.mkdir()
    shutil.copy(out, bare)
    assert QgsRasterLayer(str(bare), "bare").renderer().type() == "multibandcolor"
    layer = QgsRasterLayer(str(out), "dsm")
    assert layer.isValid()
    import rasterio
    with rasterio.open(out) as ds:
        heights = ds.read(1, masked=True).compressed()
    _assert_height_in_pseudocolour(layer, heights)
    assert layer.renderer().usesBands() == [1]
