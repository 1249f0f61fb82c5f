"""Nearest-neighbour resampling is pixel-identical to ``gdalwarp -r near -et 0`` (issue 15).

GDAL takes the source pixel ``floor(x + 1e-10)`` of a position computed in float64 through
``GDALInvGeoTransform`` and ``GDALApplyGeoTransform``; fotogeo does the same
(:func:`fotogeo.io.warp.nearest_source_pixels`, :class:`fotogeo.io.warp.GeotransformInverse`), so
even grids whose every output centre falls exactly on a source pixel corner (a 2x coarser grid
aligned with the source) come out the same. The real rasters cover per-band nodata (Landsat:
a dark pixel with one channel at 0 stays) and a pixel size with no exact binary form (300.0379 m).
"""
from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
import rasterio
from affine import Affine

from fotogeo.io.warp import warp_to_grid
from fotogeo.io.warp_gdal import GeotransformInverse, gdal_inverse_geotransform, nearest_source_pixels

CRS = "EPSG:32735"
GDALWARP = shutil.which("gdalwarp")
needs_gdalwarp = pytest.mark.skipif(GDALWARP is None, reason="gdalwarp (Debian's gdal-bin) is not installed")


def _plain_inverse(T):
    """The same mapping through affine's own inverse (other rounding): the control that shows the ties matter."""
    i = ~T

    def inverse(XY):
        return np.column_stack([i.a * XY[:, 0] + i.b * XY[:, 1] + i.c, i.d * XY[:, 0] + i.e * XY[:, 1] + i.f])
    return inverse


def _gdalwarp(src, dst, t, w, h, nodata=None):
    """``gdalwarp`` onto the grid (t, w, h): -te and -tr, so its geotransform is ``t`` exactly."""
    cmd = [GDALWARP, "-q", "-overwrite", "-et", "0", "-r", "near", "-te", repr(t.c), repr(t.f + t.e * h),
           repr(t.c + t.a * w), repr(t.f), "-tr", repr(t.a), repr(-t.e)]
    cmd += [] if nodata is None else ["-dstnodata", str(nodata)]
    subprocess.run([*cmd, str(src), str(dst)], check=True)
    with rasterio.open(dst) as ds:
        assert ds.transform == t and (ds.width, ds.height) == (w, h)
        return ds.read()


def _fotogeo(src, dst, inverse, t, w, h, nodata=None, threads=2):
    with rasterio.open(src) as ds:
        crs = ds.crs
    warp_to_grid(src, dst, inverse, crs=crs, transform=t, width=w, height=h, nodata=nodata, block=128,
                 threads=threads, overviews=False)
    with rasterio.open(dst) as ds:
        return ds.read()


def _differing(a, b) -> int:
    return int((a != b).any(axis=0).sum())


def _aligned_grid(T, width, height, factor, shift=0.0):
    """A north-up grid ``factor`` times the source pixel, its corner ``shift`` source pixels from the source's."""
    res = T.a * factor
    t = Affine(res, 0.0, T.c + shift * T.a, 0.0, -res, T.f - shift * T.a)
    return t, int(width / factor) + 2, int(height / factor) + 2


def test_inverse_geotransform_is_gdals():
    gdal = pytest.importorskip("osgeo.gdal")
    rng = np.random.default_rng(3)
    for k in range(200):
        rot = 0.0 if k % 3 == 0 else float(rng.uniform(-180, 180))
        res = float(rng.choice([0.1, 0.3, 1.1, 300.0379, 5.0]))
        T = (Affine.translation(float(rng.uniform(-1e6, 1e6)), float(rng.uniform(-1e7, 1e7)))
             * Affine.rotation(rot) * Affine.scale(res, -res * float(rng.choice([1.0, 1.5]))))
        mine = gdal_inverse_geotransform(T)
        theirs = gdal.InvGeoTransform(T.to_gdal())
        assert mine.to_gdal() == tuple(theirs)  # bit for bit
    with pytest.raises(ValueError, match="cannot be inverted"):
        gdal_inverse_geotransform(Affine(1.0, 2.0, 0.0, 2.0, 4.0, 0.0))


def test_nearest_rule_at_ties_and_edges():
    """Within 1e-10 below an edge is the next pixel; the far edge itself is outside, 2e-10 below it is inside."""
    sp = np.array([[3.0 - 1e-11, 0.0], [3.0 - 1e-9, 0.0], [10.0, 0.0], [10.0 - 1e-11, 5.0], [10.0 - 2e-10, 9.999999]])
    col, row, inside = nearest_source_pixels(sp, 10, 10)
    assert col.tolist() == [3, 2, -1, -1, 9] and row.tolist() == [0, 0, -1, -1, 9]
    assert inside.tolist() == [True, True, False, False, True]


@needs_gdalwarp
@pytest.mark.parametrize("origin,res,factor", [((741891.3, 2530591.4), 0.3, 2.0),
                                               ((792919.4, 8318543.1), 1.1, 2.0),
                                               ((500000.25, 7000000.75), 0.1, 3.0)])
def test_identical_to_gdalwarp_on_exact_ties(tmp_path, origin, res, factor):
    """Every output centre is exactly on a source pixel edge; gdalwarp and fotogeo agree on every
    pixel, while the same mapping in another (equally exact) arithmetic would not — for the first
    two grids the ties decide more than a fifth of the pixels."""
    n = 600
    T = Affine(res, 0.0, origin[0], 0.0, -res, origin[1])
    rng = np.random.default_rng(7)
    with rasterio.open(tmp_path / "s.tif", "w", driver="GTiff", width=n, height=n, count=2, dtype="uint8",
                       crs=CRS, transform=T, tiled=True) as ds:
        ds.write(rng.integers(1, 256, (2, n, n)).astype("uint8"))
    t, w, h = _aligned_grid(T, n, n, factor)
    theirs = _gdalwarp(tmp_path / "s.tif", tmp_path / "g.tif", t, w, h, nodata=0)
    ours = _fotogeo(tmp_path / "s.tif", tmp_path / "f.tif", GeotransformInverse(T), t, w, h)
    assert (theirs[0] > 0).sum() == n * n // factor ** 2 or factor != 2.0
    assert _differing(ours, theirs) == 0
    plain = _fotogeo(tmp_path / "s.tif", tmp_path / "p.tif", _plain_inverse(T), t, w, h)
    if factor == 2.0:
        assert _differing(plain, theirs) > 0.2 * w * h


@needs_gdalwarp
def test_identical_to_gdalwarp_rotated_source(tmp_path):
    """A rotated source read onto a north-up grid (the resampling benchmark's case, smaller)."""
    n = 700
    T = Affine.translation(500000, 7000000) * Affine.rotation(13.3) * Affine.scale(0.5, -0.5)
    rng = np.random.default_rng(11)
    with rasterio.open(tmp_path / "s.tif", "w", driver="GTiff", width=n, height=n, count=3, dtype="uint8",
                       crs=CRS, transform=T, tiled=True) as ds:
        ds.write(rng.integers(1, 256, (3, n, n)).astype("uint8"))
    from fotogeo.io.warp import grid_covering
    from fotogeo.pixels import outline, pixel_to_map
    t, w, h = grid_covering(pixel_to_map(T, outline(n, n, 5)), 0.5)
    theirs = _gdalwarp(tmp_path / "s.tif", tmp_path / "g.tif", t, w, h, nodata=0)
    ours = _fotogeo(tmp_path / "s.tif", tmp_path / "f.tif", GeotransformInverse(T), t, w, h, threads=3)
    assert _differing(ours, theirs) == 0 and (ours[0] > 0).sum() == n * n


@needs_gdalwarp
@pytest.mark.parametrize("name,factor,shift,nodata", [("landsat_rgb/RGB.byte.tif", 2.0, 0.0, None),
                                                      ("landsat_rgb/RGB.byte.tif", 0.7, 0.3, None),
                                                      ("landsat_rgb/RGB.byte.tif", 1.0, 0.0, 255),
                                                      ("ngi/ortho/ngi_rgb_byte_1.tif", 2.0, 0.0, None),
                                                      ("ngi/sentinel2_b432_byte.tif", 0.5, 0.25, None)])
def test_identical_to_gdalwarp_on_real_rasters(tmp_path, data_dir, name, factor, shift, nodata):
    src = tmp_path / "s.tif"
    shutil.copy(data_dir / name, src)
    with rasterio.open(src) as ds:
        T, W, H = ds.transform, ds.width, ds.height
    t, w, h = _aligned_grid(T, W, H, factor, shift)
    theirs = _gdalwarp(src, tmp_path / "g.tif", t, w, h, nodata=nodata)
    ours = _fotogeo(src, tmp_path / "f.tif", GeotransformInverse(T), t, w, h, nodata=nodata)
    assert _differing(ours, theirs) == 0
    if "landsat" in name:  # per-band nodata: dark pixels with one channel at 0 exist and are kept as GDAL keeps them
        nd = 0 if nodata is None else nodata
        assert ((ours == nd).any(axis=0) & (ours != nd).any(axis=0)).sum() > 100
