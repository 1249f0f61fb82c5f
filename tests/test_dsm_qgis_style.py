"""The DSM's QGIS style: ``fotogeo dsm`` writes ``<name>.qml`` beside ``<name>.tif`` (QGIS loads it as the layer's
default style: band 1, the height, in pseudocolour over its 2 … 98 % — not an RGB of height, pairs and spread), in
the run's atomic set of outputs: refused up front when it exists without ``overwrite``, replaced with it, never
left by a failed run. The desktop's own reading of it: tests/test_qgis_dsm_style.py.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from fotogeo.errors import OutputError

CRS = "EPSG:32635"
PLUGIN_STYLE = Path(__file__).resolve().parents[1] / "processing_provider" / "styles" / "dsm.qml"


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    from rendered_pair import render
    return render(tmp_path_factory.mktemp("pair"), 256)


def _run(pair, out, **kw):
    from fotogeo.tools.dsm import dsm
    return dsm(pair["images"], out, camera=pair["camera"], eo=pair["eo"], crs=CRS, **kw)


def _renderer(qml: Path):
    return ET.parse(qml).getroot().find("pipe/rasterrenderer")


def test_the_dsm_has_its_qgis_style_beside_it_over_its_heights(pair, tmp_path):
    import rasterio
    out = tmp_path / "block.dsm.tif"
    rep = _run(pair, out, report=tmp_path / "r.json")
    style = tmp_path / "block.dsm.qml"  # QGIS: <folder>/<complete base name>.qml
    assert rep["outputs"]["qgis_style"] == str(style)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["block.dsm.qml", "block.dsm.tif", "r.json"]
    r = _renderer(style)
    assert r.get("type") == "singlebandpseudocolor" and r.get("band") == "1"
    with rasterio.open(out) as ds:
        h = ds.read(1, masked=True).compressed()
    lo, hi = float(r.get("classificationMin")), float(r.get("classificationMax"))
    assert lo == pytest.approx(np.quantile(h, 0.02), abs=0.05) and hi == pytest.approx(np.quantile(h, 0.98), abs=0.05)
    items = r.findall("rastershader/colorrampshader/item")
    assert float(items[0].get("value")) == lo and float(items[-1].get("value")) == hi
    # the plugin's style, its colours and legend: one look for the DSM whichever way it is opened
    plugin = _renderer(PLUGIN_STYLE)
    assert [i.get("color") for i in items] == [i.get("color") for i in plugin.findall(
        "rastershader/colorrampshader/item")]
    legend = "rastershader/colorrampshader/rampLegendSettings"
    assert r.find(legend).get("suffix") == plugin.find(legend).get("suffix") == " m"


def test_an_existing_style_is_refused_up_front_and_replaced_with_overwrite(pair, tmp_path):
    out, style = tmp_path / "d.tif", tmp_path / "d.qml"
    style.write_text("a style the user saved")
    with pytest.raises(OutputError, match=r"QGIS style of the DSM '.*d\.qml' exists; pass overwrite"):
        _run(pair, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.qml"] and style.read_text() == "a style the user saved"
    _run(pair, out, overwrite=True)
    assert _renderer(style).get("type") == "singlebandpseudocolor"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.qml", "d.tif"]


def test_triangulate_refuses_an_existing_style_of_its_dsm_before_the_adjustment(pair, tmp_path):
    """Before: found by the DSM step, after the whole adjustment."""
    from fotogeo.tools.triangulate import triangulate
    (tmp_path / "d.qml").write_text("a style the user saved")
    with pytest.raises(OutputError, match=r"QGIS style of the DSM '.*d\.qml' exists"):
        triangulate(pair["images"], pair["camera"], pair["eo"], None, tmp_path / "block", crs=CRS,
                    dsm=tmp_path / "d.tif")
    assert not (tmp_path / "block").exists() or not any((tmp_path / "block").iterdir())


def test_a_style_that_would_restyle_an_input_is_refused(pair, tmp_path):
    """``-o <images' folder>/<an image's name>.tiff``: its ``<name>.qml`` would make QGIS open that input image as
    heights; refused before any work, nothing written."""
    import shutil
    src = Path(pair["images"][0])
    folder = tmp_path / "w"
    folder.mkdir()
    images = [shutil.copy(p, folder / Path(p).name) for p in pair["images"]]
    from fotogeo.tools.dsm import dsm
    with pytest.raises(OutputError, match="restyle the input"):
        dsm(images, folder / f"{src.stem}.tiff", camera=pair["camera"], eo=pair["eo"], crs=CRS)
    assert sorted(p.name for p in folder.iterdir()) == sorted(Path(p).name for p in pair["images"])
