"""Orthorectification reads a source's reduced level when the output samples it coarsely (fotogeo.io.warp_levels):
a JPEG's DCT-scaled level or a file's own overviews, at the largest power-of-two factor not above the output cell's
narrowest size in source pixels (within GDAL's 1 %); the result lies where the full-resolution one does (no shift)
and on the rendered scene's truth; nearest neighbour, fine grids, masked sources and levels of another size read
the full resolution, unchanged."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import rasterio
from affine import Affine
from rasterio.shutil import copy as rcopy

import box_scene as bs
import fotogeo.io.warp as warp
from fotogeo.io.warp import make_plan, warp_to_grid
from fotogeo.io.warp_levels import ReducedMapping, cell_scale, reduction_factor
from fotogeo.tools.ortho.tool import ortho


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("reduced")
    paths = bs.write_scene(d)
    paths["jpeg"] = d / "frame.jpg"
    rcopy(paths["frame"], paths["jpeg"], driver="JPEG", QUALITY=95)
    return paths


def _ortho(scene, out, resolution, resampling="bilinear"):
    rep = ortho([str(scene["jpeg"])], str(out), dem=str(scene["dem"]), camera=str(scene["camera"]),
                eo=str(scene["eo"]), resolution=resolution, resampling=resampling)
    with rasterio.open(out) as ds:
        return rep["images"]["frame"], ds.read(1).astype(np.float32), ds.read_masks(1) > 0, ds.transform


def _full_resolution(monkeypatch):
    monkeypatch.setattr(warp, "reduced_plan", lambda path, src, plan, w, h: plan)


def _shift(img, ref, ok):
    """The least-squares shift ``d`` (output pixels, x and y) with ``img(p) = ref(p + d)`` over the cells ``ok``
    (first order: ``img - ref = grad(ref) . d``; a symmetric blur of one against the other does not bias it)."""
    gy, gx = np.gradient(ref)
    ok = ok & np.isfinite(gx) & np.isfinite(gy) & np.isfinite(img)
    return np.linalg.lstsq(np.column_stack([gx[ok], gy[ok]]), (img - ref)[ok], rcond=None)[0]


def test_a_coarse_ortho_reads_the_jpeg_at_half_resolution_where_the_full_one_lies(scene, tmp_path, monkeypatch):
    # the frame's pixel is 0.5 m on the ground: a 1.25 m cell spans 2.5 pixels -> the 1/2 level (1.0 m)
    entry, reduced, ok_r, t = _ortho(scene, tmp_path / "reduced.tif", 1.25)
    assert entry["source_factor"] == 2
    _full_resolution(monkeypatch)
    full_entry, full, ok_f, t_f = _ortho(scene, tmp_path / "full.tif", 1.25)
    assert "source_factor" in full_entry and full_entry["source_factor"] == 1 and t == t_f
    both = ok_r & ok_f
    assert both.sum() > 0.97 * ok_f.sum()  # the reduced read's footprint: half a reduced pixel less at the rim
    assert not np.array_equal(reduced[both], full[both])  # another source image was read
    rows, cols = np.nonzero(both)
    XY = np.column_stack(t * (cols + 0.5, rows + 0.5))
    seen = ~bs.hidden_from_camera(XY, 2.0) & ~bs.on_a_box(XY, 2.0)  # bare ground, seen, 2 m from the boxes
    truth = np.full(reduced.shape, np.nan)
    truth[rows[seen], cols[seen]] = bs.texture(XY[seen, 0], XY[seen, 1])
    ground = np.isfinite(truth)
    assert ground.sum() > 0.5 * both.sum()
    for img in (reduced, full):  # both on the rendered truth: no shift, grey levels near it
        assert np.abs(_shift(img, truth, ground)).max() < 0.01  # output pixels
        err = np.abs(img - truth)[ground]
        assert np.median(err) < 1.0 and np.percentile(err, 99) < 3.0


@pytest.mark.parametrize("resolution,resampling", [(0.75, "bilinear"), (1.25, "nearest")],
                         ids=["fine-grid", "nearest"])
def test_fine_grids_and_nearest_read_the_full_resolution(scene, tmp_path, monkeypatch, resolution, resampling):
    entry, a, ok_a, _ = _ortho(scene, tmp_path / "a.tif", resolution, resampling)
    assert entry["source_factor"] == 1
    _full_resolution(monkeypatch)
    _, b, ok_b, _ = _ortho(scene, tmp_path / "b.tif", resolution, resampling)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(ok_a, ok_b)


def test_cell_scale_is_the_narrowest_size_of_a_cell_in_source_pixels():
    c, s = np.cos(0.3), np.sin(0.3)
    A = np.array([[2.5 * c, -2.5 * s], [1.7 * s, 1.7 * c]])  # a rotated cell of 2.5 x 1.7 source pixels

    def inverse(XY):
        return (np.asarray(XY) - [1000.0, 2000.0]) @ A.T

    t = Affine(1.0, 0, 1000.0, 0, 1.0, 2000.0)
    assert cell_scale(inverse, t, 100, 80, 1000, 1000) == pytest.approx(1.7, abs=1e-9)
    assert cell_scale(inverse, t, 100, 80, 1000, 1000, n=5) == pytest.approx(1.7, abs=1e-9)
    assert cell_scale(lambda XY: np.asarray(XY) * 0 - 5.0, t, 100, 80, 1000, 1000) is None  # outside the source
    m = ReducedMapping(inverse, 4)
    assert not hasattr(m, "grid")
    np.testing.assert_allclose(m([[1010.0, 2020.0]]), inverse([[1010.0, 2020.0]]) / 4)


def _jpeg(path, width, height):
    rng = np.random.default_rng(1)
    a = cv2.GaussianBlur((rng.random((height, width)) * 255).astype(np.float32), (0, 0), 3).astype(np.uint8)
    tif = path.with_suffix(".tif")
    with rasterio.open(tif, "w", driver="GTiff", width=width, height=height, count=1, dtype="uint8") as ds:
        ds.write(a, 1)
    rcopy(tif, path, driver="JPEG", QUALITY=90)
    return path


@pytest.mark.parametrize("scale,factor", [(1.97, None), (1.985, 2), (3.9, 2), (4.5, 4), (9.0, 8)])
def test_the_level_read_is_the_largest_factor_within_the_cell(tmp_path, scale, factor):
    src_path = _jpeg(tmp_path / "s.jpg", 1024, 768)
    t = Affine(scale, 0, 0, 0, scale, 0)  # map units = source pixels; one cell = `scale` pixels
    with rasterio.open(src_path) as src:
        plan = make_plan(src, lambda XY: np.asarray(XY, float), t, "bilinear")
        got = reduction_factor(src, plan, int(1024 / scale), int(768 / scale))
        assert (got[0] if got else None) == factor
        plan = make_plan(src, lambda XY: np.asarray(XY, float), t, "nearest")
        assert reduction_factor(src, plan, int(1024 / scale), int(768 / scale)) is None


def test_other_sizes_and_masked_sources_read_the_full_resolution(tmp_path):
    t = Affine(3.0, 0, 0, 0, 3.0, 0)
    with rasterio.open(_jpeg(tmp_path / "odd.jpg", 1001, 768)) as src:  # 1001 is no multiple of 2
        assert src.overviews(1)
        assert reduction_factor(src, make_plan(src, lambda XY: XY, t, "cubic"), 300, 200) is None
    with rasterio.open(_jpeg(tmp_path / "s.jpg", 1024, 768)) as src:
        assert reduction_factor(src, make_plan(src, lambda XY: XY, t, "cubic", src_nodata=0), 300, 200) is None


@pytest.mark.parametrize("scale,factor", [(2.6, 2), (4.5, 4)])
def test_a_tiff_reads_its_own_overviews_and_lies_where_the_full_resolution_does(tmp_path, scale, factor):
    src_path = tmp_path / "s.tif"
    rcopy(_jpeg(tmp_path / "s.jpg", 1024, 768), src_path, driver="GTiff")
    with rasterio.open(src_path, "r+") as ds:
        ds.build_overviews([2, 4], rasterio.enums.Resampling.average)
    c, s = np.cos(0.2), np.sin(0.2)

    def inverse(XY):  # map -> source pixel: a rotation and `scale` source pixels per map unit
        XY = np.asarray(XY, float) - [150.0, 100.0]
        return np.column_stack([scale * (c * XY[:, 0] - s * XY[:, 1]) + 512,
                                scale * (s * XY[:, 0] + c * XY[:, 1]) + 384])

    t, out = Affine(1.0, 0, 0, 0, 1.0, 0), {}
    for reduce in (True, False):
        summary = warp_to_grid(src_path, tmp_path / f"{reduce}.tif", inverse, crs="EPSG:32631", transform=t,
                               width=300, height=200, resampling="bilinear", reduce=reduce, overviews=False)
        with rasterio.open(tmp_path / f"{reduce}.tif") as ds:
            out[reduce] = (summary, ds.read(1).astype(np.float32), ds.read_masks(1) > 0)
    assert out[True][0]["source_factor"] == factor and "source_factor" not in out[False][0]
    both = out[True][2] & out[False][2]
    assert both.sum() > 0.9 * out[False][2].sum()
    assert np.abs(_shift(out[True][1], out[False][1], both)).max() < 0.01
