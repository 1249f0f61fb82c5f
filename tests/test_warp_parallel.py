"""Parallel window resampling and tiled warps (issue 15): the pixels never depend on the thread
count, the tiling or the executor; nearest neighbour equals a plain per-pixel lookup (GDAL's
floor rule); nodata and NaN keep their rules."""
from __future__ import annotations

import concurrent.futures as cf
import hashlib

import numpy as np
import pytest
import rasterio
from affine import Affine

from fotogeo.io.warp import grid_covering, warp_to_grid
from fotogeo.io.warp_tiles import tile_windows, warp_tiled
from fotogeo.pixels import outline, pixel_to_map

CRS = "EPSG:32635"
SRC_T = Affine.translation(500000, 7000000) * Affine.rotation(13.3) * Affine.scale(2.0, -2.0)


def _source(path, dtype="uint8", bands=3, size=(300, 260), nodata=None, holes=False, seed=0):
    rng = np.random.default_rng(seed)
    h, w = size
    if np.dtype(dtype).kind == "f":
        data = rng.normal(100, 30, (bands, h, w)).astype(dtype)
    else:
        info = np.iinfo(dtype)
        data = rng.integers(max(info.min, -1000), min(info.max, 1000) + 1, (bands, h, w)).astype(dtype)
    if holes:
        data[:, 40:60, 30:90] = np.nan if np.dtype(dtype).kind == "f" else (nodata or 0)
        if np.dtype(dtype).kind == "f":
            data[1, 100:105, 10:20] = np.inf
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=bands, dtype=dtype, crs=CRS,
                       transform=SRC_T, nodata=nodata) as ds:
        ds.write(data)
    return data


def _inverse(XY):
    inv = ~SRC_T
    return np.column_stack([inv.a * XY[:, 0] + inv.b * XY[:, 1] + inv.c, inv.d * XY[:, 0] + inv.e * XY[:, 1] + inv.f])


def _grid(res=1.7, size=(300, 260)):
    return grid_covering(pixel_to_map(SRC_T, outline(size[1], size[0], 5)), res)


def _read(path):
    with rasterio.open(path) as ds:
        return ds.read(), ds.nodata, ds.overviews(1)


def _warp(src, dst, threads, resampling="nearest", block=64, **kw):
    t, w, h = _grid()
    return warp_to_grid(src, dst, _inverse, crs=CRS, transform=t, width=w, height=h, resampling=resampling,
                        block=block, threads=threads, **kw)


@pytest.mark.parametrize("resampling", ["nearest", "bilinear", "cubic"])
@pytest.mark.parametrize("dtype,nodata", [("uint8", None), ("int16", -9), ("float32", None)])
def test_thread_count_never_changes_pixels(tmp_path, resampling, dtype, nodata):
    _source(tmp_path / "s.tif", dtype, nodata=nodata, holes=True)
    results = []
    for threads in (1, 3):
        out = tmp_path / f"o{threads}.tif"
        summary = _warp(tmp_path / "s.tif", out, threads, resampling)
        data, nd, ovr = _read(out)
        results.append((hashlib.sha1(data.tobytes()).hexdigest(), summary, repr(nd), ovr))
    assert results[0] == results[1]
    assert results[0][1]["valid_pixels"] > 0


def test_nearest_equals_plain_lookup(tmp_path):
    """Every output pixel is the source pixel containing its centre's preimage — floor(x + 1e-10) in
    float64, GDAL's rule, ties included — or nodata outside."""
    src = _source(tmp_path / "s.tif", "uint8", size=(300, 260))
    _warp(tmp_path / "s.tif", tmp_path / "o.tif", threads=2)
    out, nd, _ = _read(tmp_path / "o.tif")
    t, w, h = _grid()
    cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    XY = np.column_stack([t.c + cols.ravel() * t.a + rows.ravel() * t.b, t.f + cols.ravel() * t.d + rows.ravel() * t.e])
    sp = _inverse(XY)
    ci, ri = np.floor(sp[:, 0] + 1e-10).astype(int), np.floor(sp[:, 1] + 1e-10).astype(int)
    inside = (sp[:, 0] >= 0) & (sp[:, 0] + 1e-10 <= 260) & (sp[:, 1] >= 0) & (sp[:, 1] + 1e-10 <= 300)
    ci, ri = np.minimum(ci, 259), np.minimum(ri, 299)
    flat = out.reshape(3, -1)
    assert (flat[:, inside] == src[:, ri[inside], ci[inside]]).all()
    assert (flat[:, ~inside] == nd).all() and inside.sum() > 0.5 * inside.size


def test_nan_and_nodata_rules_kept(tmp_path):
    """NaN/inf in a float source become the output's NaN nodata; a signed source's nodata stays its own."""
    _source(tmp_path / "f.tif", "float32", holes=True)
    s = _warp(tmp_path / "f.tif", tmp_path / "fo.tif", threads=2)
    data, nd, _ = _read(tmp_path / "fo.tif")
    assert np.isnan(nd) and s["nodata"] is None and np.isfinite(data[~np.isnan(data)]).all()
    assert int((~np.isnan(data[0])).sum()) == s["valid_pixels"]
    _source(tmp_path / "i.tif", "int16", nodata=-9, holes=True)
    s = _warp(tmp_path / "i.tif", tmp_path / "io.tif", threads=2)
    data, nd, _ = _read(tmp_path / "io.tif")
    # nodata is per band (as in GDAL): a pixel is valid where any band differs from it
    assert nd == -9 and s["nodata"] == -9 and int((data != -9).any(axis=0).sum()) == s["valid_pixels"]
    assert ((data == -9).any(axis=0) & (data != -9).any(axis=0)).sum() > 0  # such mixed pixels exist and stay


def test_cancel_stops_the_pool(tmp_path):
    from fotogeo.errors import Cancelled
    from fotogeo.progress import Progress
    _source(tmp_path / "s.tif")
    seen = []

    def stop_after_three(fraction, message):
        seen.append(message)
        return len(seen) < 3

    with pytest.raises(Cancelled):
        _warp(tmp_path / "s.tif", tmp_path / "o.tif", threads=2, progress=Progress(stop_after_three))


def test_tile_windows_cover_the_grid_once():
    tiles = tile_windows(1000, 777, 256)
    cover = np.zeros((1000, 777), int)
    for r0, c0, h, w in tiles:
        cover[r0:r0 + h, c0:c0 + w] += 1
    assert (cover == 1).all()


@pytest.mark.parametrize("executor", ["threads", "processes"])
def test_tiled_warp_is_pixel_identical(tmp_path, executor):
    """Tiles written by separate tasks (threads, or processes: the plan is pickled) and assembled
    into a COG give the one-process warp's pixels; the tile folder is removed."""
    _source(tmp_path / "s.tif", "uint8")
    _warp(tmp_path / "s.tif", tmp_path / "one.tif", threads=1)
    t, w, h = _grid()
    pool = (cf.ThreadPoolExecutor(2) if executor == "threads" else
            cf.ProcessPoolExecutor(2, mp_context=__import__("multiprocessing").get_context("spawn")))
    with pool:
        summary = warp_tiled(tmp_path / "s.tif", tmp_path / "cog.tif", _inverse, crs=CRS, transform=t, width=w,
                             height=h, tile=100, block=64, executor=pool)
    assert summary["tiles"] == len(tile_windows(h, w, 128))
    one, nd1, _ = _read(tmp_path / "one.tif")
    cog, nd2, ovr = _read(tmp_path / "cog.tif")
    assert (one == cog).all() and nd1 == nd2
    with rasterio.open(tmp_path / "cog.tif") as ds:
        assert ds.transform == t and ds.crs.to_epsg() == 32635 and ds.profile["tiled"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cog.tif", "one.tif", "s.tif"]


@pytest.mark.parametrize("resampling", ["nearest", "bilinear", "cubic"])
@pytest.mark.parametrize("nodata,holes", [(None, False), (0, True)])
def test_windows_inside_a_valid_source_skip_the_mask_remap_with_the_same_pixels(tmp_path, monkeypatch, resampling,
                                                                                 nodata, holes):
    """A window whose kernels all lie inside an all-valid source window skips the mask's remap (all 255 there):
    the output equals the one with every mask remapped, at the source's edges, its nodata holes and inside."""
    import fotogeo.io.warp as warp
    src = tmp_path / "src.tif"
    _source(src, nodata=nodata, holes=holes)
    _warp(src, tmp_path / "skip.tif", 1, resampling, block=32)
    skipped = []
    for name in ("_nearest_maps", "_interpolation_maps"):
        def never_within(*a, _f=getattr(warp, name)):
            r = _f(*a)
            if r is not None:
                skipped.append(r[-1])
            return None if r is None else (*r[:-1], False)
        monkeypatch.setattr(warp, name, never_within)
    _warp(src, tmp_path / "remap.tif", 1, resampling, block=32)
    assert any(skipped) and not all(skipped)  # both kinds of window occur
    a, b = _read(tmp_path / "skip.tif")[0], _read(tmp_path / "remap.tif")[0]
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("nearest", [False, True])
def test_remapped_validity_equals_the_mask_remap_cell_for_cell(nearest):
    """An all-valid source window's validity from the fixed-point maps (only the cells straddling the window's edge
    remapped) equals ``cv2.remap`` of the whole all-255 mask: positions in 1/32-px steps across every edge, where
    taps of weight 1-3 of 1024 fall outside, and NaN positions."""
    import cv2

    from fotogeo.io.warp_source import remapped_validity
    rng = np.random.default_rng(3)
    h, w = 37, 53  # the source window
    x = rng.integers(-3 * 32, (w + 2) * 32, (120, 90)) / 32 + rng.choice([0, 1 / 64, -1 / 64], (120, 90))
    y = rng.integers(-3 * 32, (h + 2) * 32, (120, 90)) / 32
    x[:3, :3] = np.nan
    mx, my = x.astype(np.float32), y.astype(np.float32)
    if nearest:
        mx, my = np.round(np.nan_to_num(mx, nan=-1)), np.round(my)
    map1, map2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    if nearest:
        map2 = None
    full = cv2.remap(np.full((h, w), 255, np.uint8), map1, map2, cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    want = full > 0 if nearest else full >= 255
    got = remapped_validity(map1, map2, h, w)
    assert want.any() and not want.all() and (nearest or ((full > 0) & (full < 255)).any())  # edges straddled
    np.testing.assert_array_equal(got, want)
