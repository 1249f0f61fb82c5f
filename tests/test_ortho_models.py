"""``fotogeo ortho IMAGE --model R.json --dem DEM`` (issue 21): orthophotos through a fitted ``orient`` model, on
the NGI frame 0182 with GCPs from its true geometry (as tests/test_orient.py), against the collinearity
orthophoto of its camera and exterior orientation on the same aligned grid."""
from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.tools.orient.tool import orient
from fotogeo.tools.ortho.tool import ortho
from test_bad_input import assert_one_line_error
from test_ortho import _tile_shifts
from test_orient import NAME, ngi_gcps  # noqa: F401 - the module fixture the GCPs come from

RES = 5.0


@pytest.fixture(scope="module")
def ngi(ngi_gcps):  # noqa: F811 - the fixture imported above, requested by name
    """test_orient's GCPs of frame 0182 and the collinearity orthophoto of its true camera and orientation."""
    g = ngi_gcps
    truth = g["dir"] / "collinearity.tif"
    ortho([str(g["image"])], str(truth), dem=str(g["ngi"] / "dem.tif"),
          camera=str(g["ngi"] / "interior_orientation.yaml"), eo=str(g["ngi"] / "exterior_orientation.txt"),
          resolution=RES, resampling="bilinear")
    return {"ngi": g["ngi"], "gcps": g["path"], "image": g["image"], "truth": truth}


def _on_common_grid(a_path, b_path):
    """Band 1 of two rasters on one aligned lattice, cut to their common window."""
    with rasterio.open(a_path) as a, rasterio.open(b_path) as b:
        ta, tb = a.transform, b.transform
        assert ta.a == tb.a and ((ta.c - tb.c) / ta.a) % 1 == 0 and ((ta.f - tb.f) / ta.e) % 1 == 0
        x0, x1 = max(ta.c, tb.c), min(ta.c + a.width * ta.a, tb.c + b.width * tb.a)
        y0, y1 = min(ta.f, tb.f), max(ta.f + a.height * ta.e, tb.f + b.height * tb.e)
        out = []
        for ds in (a, b):
            t = ds.transform
            c0, r0 = round((x0 - t.c) / t.a), round((y0 - t.f) / t.e)
            w, h = round((x1 - x0) / t.a), round((y1 - y0) / t.e)
            out.append(ds.read(1, window=((r0, r0 + h), (c0, c0 + w))).astype(np.float32))
    return out


@pytest.mark.parametrize("model, limit", [("dlt", 0.5), ("collinearity", 0.5)])
def test_fitted_model_orthophoto_lands_on_the_collinearity_one(ngi, tmp_path, model, limit):
    """A 3-D model fitted on 40 GCPs (0.3 px noise) orthorectifies the frame onto the same ground as its true
    camera and exterior orientation: median local shift (phase correlation, 128² tiles) under half a pixel."""
    rep_path = tmp_path / f"{model}.json"
    orient(ngi["image"], ngi["gcps"], model=model, report=rep_path, camera=ngi["ngi"] / "interior_orientation.yaml")
    out = tmp_path / f"{model}.tif"
    rep = ortho([str(ngi["image"])], str(out), model=str(rep_path), dem=str(ngi["ngi"] / "dem.tif"),
                resolution=RES, resampling="bilinear")
    assert rep["crs_rule"].startswith("the CRS of the fitted model")
    assert rep["images"][NAME + "_RGB"]["kind"] == "fitted"
    ours, truth = _on_common_grid(out, ngi["truth"])
    valid = (ours > 0) & (truth > 0)
    assert valid.mean() > 0.8
    s = _tile_shifts(ours, truth, valid)
    assert len(s) >= 15
    assert np.median(np.hypot(s[:, 0], s[:, 1])) < limit


def test_fitted_models_refused_where_they_cannot_orthorectify(ngi, tmp_path):
    """An image → ground fit, a report that is not orient's, several images or a camera beside --model: one line
    each, nothing written."""
    rep = tmp_path / "i2g.json"
    orient(ngi["image"], ngi["gcps"], model="rfm-poly-i2g", report=rep)
    good = tmp_path / "poly1.json"
    orient(ngi["image"], ngi["gcps"], model="poly1", report=good)
    out = tmp_path / "o.tif"
    base = ["ortho", str(ngi["image"]), "--dem", str(ngi["ngi"] / "dem.tif"), "--resolution", "10", "-o", str(out),
            "-q"]
    cases = [(["--model", str(rep)], "fitted image → ground"),
             (["--model", str(ngi["truth"].with_suffix(".json"))], "cannot be read"),
             (["--model", str(good), "--camera", str(ngi["ngi"] / "interior_orientation.yaml")], "give one image"),
             (["--model", str(good), str(ngi["truth"])], "give one image")]
    not_orient = tmp_path / "other.json"
    not_orient.write_text(json.dumps({"fotogeo": "triangulate"}))
    cases.append((["--model", str(not_orient)], "is not a report of fotogeo orient"))
    for extra, expected in cases:
        assert_one_line_error(CliRunner().invoke(main, base + extra), expected)
        assert not out.exists()


def test_model_file_named_after_the_option_keeps_its_name(tmp_path):
    """A refusal about ``--model model.json`` named the file ``'--model.json'``: the message spelled the flag and
    the CLI put its flag on the next word ``model`` too (:func:`fotogeo.errors.in_callers_words`, first occurrence);
    now the message says the keyword once and the file keeps its name."""
    img = tmp_path / "img.tif"
    with rasterio.open(img, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8") as ds:
        ds.write(np.zeros((1, 16, 16), np.uint8))
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"fotogeo": "triangulate"}))
    r = CliRunner().invoke(main, ["ortho", str(img), "--model", str(model), "--height", "0", "-o",
                                  str(tmp_path / "o.tif"), "-q"])
    assert_one_line_error(r, f"--model {str(model)!r} is not a report of fotogeo orient")
