"""fotogeo dsm's source images: an untiled image (JPEG, PNG, a GeoTIFF in strips) small enough is decoded once per
process and its windows sliced from it — the same pixels as GDAL's windowed reads — while a tiled GeoTIFF is
still read by windows; the decoded image never travels with a pickled source (a Dask task)."""
from __future__ import annotations

import os
import pickle

import numpy as np
import pytest
import rasterio
from rasterio.windows import Window

from fotogeo.io.raster import ropen
from fotogeo.tools.dsm import inputs
from fotogeo.tools.dsm.inputs import DECODED, SourceImage


@pytest.fixture(autouse=True)
def _empty_cache():
    DECODED.clear()
    yield
    DECODED.clear()


def _write(path, data, driver="GTiff", **kw):
    with rasterio.open(path, "w", driver=driver, width=data.shape[2], height=data.shape[1], count=len(data),
                       dtype=data.dtype, **kw) as ds:
        ds.write(data)
    return path


def _windows(src, rng, n=12):
    for _ in range(n):
        x0, y0 = int(rng.integers(0, src.width - 2)), int(rng.integers(0, src.height - 2))
        yield x0, y0, int(rng.integers(x0 + 1, src.width + 1)), int(rng.integers(y0 + 1, src.height + 1))


def _gdal(path, bands, x0, y0, x1, y1):
    with ropen(path) as ds:
        return ds.read(indexes=bands, window=Window(x0, y0, x1 - x0, y1 - y0))


@pytest.mark.parametrize("kind", ["jpeg", "png", "strips"])
def test_untiled_source_is_decoded_once_and_gives_the_windowed_pixels(tmp_path, kind):
    rng = np.random.default_rng(5)
    data = rng.integers(0, 255, (3, 150, 170)).astype(np.uint8)
    data = np.ascontiguousarray(np.repeat(np.repeat(data, 2, axis=1), 2, axis=2)[:, :287, :333])  # odd sizes
    path = {"jpeg": lambda: _write(tmp_path / "a.jpg", data, "JPEG", quality=80),
            "png": lambda: _write(tmp_path / "a.png", data, "PNG"),
            "strips": lambda: _write(tmp_path / "a.tif", data.astype(np.uint16) * 7, compress="deflate")}[kind]()
    src = SourceImage(path)
    assert src.key is not None
    for win in _windows(src, rng):
        expected = _gdal(path, src.bands, *win)
        got = src.read(*win)
        assert got.dtype == expected.dtype and np.array_equal(got, expected)
        assert np.array_equal(src.grey(*win), np.tensordot(src.weights, expected.astype(np.float32), axes=1))
    assert len(DECODED.images) == 1
    got[:] = 0  # a read is the caller's copy: the decoded image stays as it was
    assert np.array_equal(src.read(0, 0, src.width, src.height), _gdal(path, src.bands, 0, 0, src.width, src.height))


def test_tiled_or_large_sources_keep_windowed_reads(tmp_path, monkeypatch):
    data = np.random.default_rng(6).integers(0, 4000, (3, 300, 280)).astype(np.uint16)
    tiled = SourceImage(_write(tmp_path / "t.tif", data, tiled=True, blockxsize=64, blockysize=64))
    assert tiled.key is None
    assert np.array_equal(tiled.read(10, 20, 200, 230), data[:, 20:230, 10:200])
    monkeypatch.setattr(inputs, "CACHE_IMAGE_BYTES", data.nbytes - 1)
    big = SourceImage(_write(tmp_path / "s.tif", data))
    assert big.key is None
    assert np.array_equal(big.read(10, 20, 200, 230), data[:, 20:230, 10:200])
    assert not DECODED.images


def test_pickled_source_carries_no_pixels_and_a_changed_file_is_decoded_again(tmp_path):
    data = np.random.default_rng(7).integers(0, 255, (3, 400, 500)).astype(np.uint8)
    path = _write(tmp_path / "a.tif", data)
    src = SourceImage(path)
    assert np.array_equal(src.read(0, 0, 500, 400), data) and DECODED.images
    blob = pickle.dumps(src)
    assert len(blob) < 4096 < data.nbytes
    assert np.array_equal(pickle.loads(blob).read(5, 6, 70, 80), data[:, 6:80, 5:70])
    other = data[:, ::-1].copy()
    _write(path, other)
    os.utime(path, ns=(1, 1))  # another modification time, whatever the clock's resolution
    assert np.array_equal(SourceImage(path).read(5, 6, 70, 80), other[:, 6:80, 5:70])


def test_the_cache_keeps_at_most_its_bytes(tmp_path, monkeypatch):
    data = np.zeros((1, 100, 100), np.uint8)
    monkeypatch.setattr(inputs, "CACHE_BYTES", 2 * data.nbytes)
    srcs = [SourceImage(_write(tmp_path / f"{k}.tif", data + k)) for k in range(3)]
    for k, s in enumerate(srcs):
        assert s.read(0, 0, 10, 10).max() == k
    assert [key[0] for key in DECODED.images] == [srcs[1].path, srcs[2].path]  # the least recently used went
