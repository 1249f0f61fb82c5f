"""A black (or white) collar without a nodata tag (issue 32): the outside of a turned scene stored north-up as
0,0,0 with no nodata, as ``gdalwarp`` without ``-dstnodata`` writes it. fotogeo mosaic takes the collar connected
to the border as nodata (with a note naming the file and ``gdal_edit -a_nodata``); dark pixels inside stay data."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from click.testing import CliRunner

from collar_cases import turned_inside
from fotogeo.cli import main
from fotogeo.mosaic.collar import MIN_SHARE, border_collar


X0, Y1, H, W, OVERLAP = 500000.0, 4400000.0, 240, 200, 80


def scene(h, w):
    r, c = np.mgrid[0:h, 0:w] + 0.5
    return np.stack([90 + 40 * np.sin(c / 7.0) * np.cos(r / 9.0) + k * 15 + 20 * np.sin((c + 2 * r) / 13.0)
                     for k in range(3)]).clip(1, 254).astype(np.uint8)


def _turned_pair(folder: Path, fill: int):
    """Two inputs of one scene (columns 0..W and W-OVERLAP..2W-OVERLAP), each valid inside a rectangle turned by
    20°, ``fill`` outside, no nodata; a 6 x 6 black blob inside the first's valid area. Returns the paths, the
    truth and the cells some input covers."""
    truth = scene(H, 2 * W - OVERLAP)
    truth[:, 100:106, 60:66] = 0  # a black roof inside the image: data, in the truth as in the input
    paths, covers = [], np.zeros((H, 2 * W - OVERLAP), bool)
    for k, c0 in enumerate((0, W - OVERLAP)):
        part = truth[:, :, c0:c0 + W].copy()
        inside = turned_inside(H, W, 20.0, 0.72)
        part[:, ~inside] = fill
        covers[:, c0:c0 + W] |= inside
        paths.append(folder / f"turned_{k}.tif")
        with rasterio.open(paths[-1], "w", driver="GTiff", width=W, height=H, count=3, dtype="uint8",
                           crs="EPSG:32635", transform=Affine(1.0, 0, X0 + c0, 0, -1.0, Y1)) as ds:
            ds.write(part)
    return paths, truth, covers


@pytest.mark.parametrize("fill", [0, 255])
def test_a_collar_without_nodata_is_not_blended(tmp_path, fill):
    """On main the seam crossed a collar (the first input's black or white corner where the second has data):
    measured on this scene, cells off the truth by more than 50 grey levels; now the mosaic is the truth."""
    paths, truth, covers = _turned_pair(tmp_path, fill)
    r = CliRunner().invoke(main, ["mosaic", *map(str, paths), "-o", str(tmp_path / "m.tif"), "--json"])
    assert r.exit_code == 0, r.output
    notes = [n for n in json.loads(r.stdout)["warnings"] if n.startswith("Note:")]
    assert len(notes) == 2 and "turned_0.tif' has no nodata value and a border of" in notes[0]
    assert f"gdal_edit -a_nodata {fill} turned_0.tif" in notes[0]
    assert set(json.loads(r.stdout)["result"]["collars_taken_as_nodata"]) == {"turned_0.tif", "turned_1.tif"}
    with rasterio.open(tmp_path / "m.tif") as ds:
        m = ds.read().astype(float)
    d = np.abs(m - truth).max(axis=0)[covers]
    assert (d > 50).mean() == 0 and np.abs(m.mean(axis=0)[covers] - truth.mean(axis=0)[covers]).mean() < 1.0
    assert (m[:, 100:106, 60:66] <= 1).all()  # the black roof inside stays (1: the mosaic's nodata is 0)


def test_the_collar_is_what_reaches_the_border():
    bands = scene(100, 120)
    bands[:, 40:50, 40:50] = 0  # inside: data
    assert border_collar(bands) == (None, None)
    bands[:, :, :3] = 0  # three black columns on the left edge: a collar (2.5 % of the cells)
    mask, value = border_collar(bands)
    assert value == 0 and mask[:, :3].all() and not mask[40:50, 40:50].any() and mask.sum() == 300
    few = scene(100, 120)
    few[:, 0, :int(MIN_SHARE * 12000) - 1] = 255  # fewer white cells on the edge than MIN_SHARE: data
    assert border_collar(few) == (None, None)


@pytest.mark.parametrize("value", [0, 255])
def test_a_cloud_or_lake_reaching_the_edge_is_not_a_collar(value):
    """Before: any border-connected region of 0 or 255 in every band above 0.1 % of the cells became nodata — a
    saturated cloud or snowfield (or a black lake) cut by the image's edge was dropped from the mosaic. A warp's
    or a scan's collar leaves convex data (a turned rectangle); such a bite does not."""
    bands = scene(100, 120)
    bands[:, :30, 40:80] = value  # 10 % of the cells, on the top edge
    assert border_collar(bands, (value,)) == (None, None)
    turned = scene(100, 120)
    turned[:, ~turned_inside(100, 120, 20.0, 0.72)] = value
    mask, got = border_collar(turned, (value,))
    assert got == value and mask.sum() == (~turned_inside(100, 120, 20.0, 0.72)).sum()


def test_a_large_file_is_labelled_decimated(tmp_path, monkeypatch):
    """Files above MAX_COLLAR_PIXELS are read decimated (average: a cell is collar when every pixel under it is);
    the mask, grown by one cell, reaches the mosaic through the VRT (nearest). Only a fringe of data along the
    outer edge, about one decimated cell wide, is given up; no collar pixel is blended (without the growth the
    collar's edge was feathered into the neighbour's data 10 pixels inside: 37 cells off by more than 50)."""
    import fotogeo.tools.ortho.mosaic_collar as mc
    monkeypatch.setattr(mc, "MAX_COLLAR_PIXELS", 4000)  # 240 x 200 inputs: cells of ~3.5 x 3.5 pixels
    paths, truth, covers = _turned_pair(tmp_path, 0)
    r = CliRunner().invoke(main, ["mosaic", *map(str, paths), "-o", str(tmp_path / "m.tif"), "--json"])
    assert r.exit_code == 0, r.output
    assert set(json.loads(r.stdout)["result"]["collars_taken_as_nodata"]) == {"turned_0.tif", "turned_1.tif"}
    with rasterio.open(tmp_path / "m.tif") as ds:
        m = ds.read().astype(float)
    from scipy import ndimage
    dark = (np.abs(m - truth).max(axis=0) > 50) & covers
    near_edge = ndimage.binary_dilation(~covers, iterations=5)
    assert dark.any() and not (dark & ~near_edge).any(), (dark.sum(), (dark & ~near_edge).sum())
