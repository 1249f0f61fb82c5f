"""The mosaic's nodata value (:mod:`fotogeo.tools.ortho.mosaic_nodata`), on orthophotos without one: one rule
with :func:`fotogeo.io.warp.default_nodata`, every value of ≤ 16-bit types counted on the raw type, wider types
given a nodata too."""
from types import SimpleNamespace

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from fotogeo.tools.ortho.mosaic_nodata import output_nodata, values_used


def _raster(path, values, dtype):
    a = np.asarray(values, dtype=dtype).reshape(1, 1, -1)
    with rasterio.open(path, "w", driver="GTiff", width=a.shape[2], height=1, count=1, dtype=dtype,
                       crs="EPSG:32635", transform=from_origin(500000, 4400000, 1, 1)) as ds:
        ds.write(a)
    return str(path)


def _nodata(tmp_path, values, dtype, progress=None):
    paths = [_raster(tmp_path / f"o{i}.tif", v, dtype) for i, v in enumerate(values)]
    infos = [SimpleNamespace(nodata=None, dtype=dtype)] * len(paths)
    return output_nodata(paths, infos) if progress is None else output_nodata(paths, infos, progress)


def test_an_int16_height_mosaic_gets_the_types_minimum_not_sea_level(tmp_path):
    """Review of s19: signed types preferred 0 while fotogeo.io.warp.default_nodata picks the minimum, so heights
    of 100–200 m got nodata 0 (int19 622ee5c returned 0 here): now -32768, and the other end, then the smallest
    unused value when those occur."""
    assert _nodata(tmp_path, [[100, 150], [120, 200]], "int16")[0] == -32768
    assert _nodata(tmp_path, [[-32768, 0], [5]], "int16")[0] == 32767
    assert _nodata(tmp_path, [[-128, 127, -127], [0]], "int8")[0] == -126
    assert _nodata(tmp_path, [[1, 2], [0]], "uint8")[0] == 255 and _nodata(tmp_path, [[1, 2]], "uint8")[0] == 0


@pytest.mark.parametrize("dtype", ["int8", "uint8", "int16", "uint16"])
def test_the_values_counted_on_the_raw_type_are_those_the_pixels_hold(tmp_path, dtype):
    info = np.iinfo(dtype)
    values = np.unique(np.r_[info.min, info.max, 0, 1, -1 if info.min else 2, 77]).astype(dtype)
    used = values_used([_raster(tmp_path / "a.tif", values, dtype)], dtype)
    assert np.array_equal(np.flatnonzero(used) + int(info.min), values.astype(int))


def test_every_value_used_leaves_a_mask_band_and_progress_is_reported(tmp_path):
    seen = []
    got = _nodata(tmp_path, [np.arange(256)], "uint8", lambda f: seen.append(f))
    assert got[0] is None and "every uint8 value" in got[1]
    partly = _nodata(tmp_path, [np.r_[0:100, 101:256]], "uint8", lambda f: seen.append(f))
    assert partly[0] == 100 and seen and seen[-1] == 1.0  # int19 622ee5c: no progress argument


def test_a_32_bit_mosaic_gets_a_nodata_value_the_data_lack(tmp_path):
    """int19 622ee5c gave 32-bit integer mosaics no nodata at all ("values not counted"), only a mask band."""
    assert _nodata(tmp_path, [[7, 70000]], "uint32")[0] == 0
    assert _nodata(tmp_path, [[-2 ** 31, 5]], "int32")[0] == 2 ** 31 - 1
    none, why = _nodata(tmp_path, [[-2 ** 31, 2 ** 31 - 1]], "int32")
    assert none is None and "both occur" in why


def test_a_wide_type_is_read_once_for_its_candidates(tmp_path, monkeypatch):
    """uint32 inputs: the two candidate values are looked for in one pass over the inputs (review of session 19:
    the pass sat in the list comprehension's condition and ran once per candidate)."""
    from fotogeo.tools.ortho import mosaic_nodata
    calls = []
    real = mosaic_nodata._occurring
    monkeypatch.setattr(mosaic_nodata, "_occurring", lambda *a, **k: calls.append(1) or real(*a, **k))
    assert _nodata(tmp_path, [[7, 70000], [9]], "uint32")[0] == 0
    assert len(calls) == 1
