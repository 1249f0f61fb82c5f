"""Multi-band windows (``resample_window``'s one ``cv2.remap`` for all bands, de-interleaved by ``cv2.split`` into
the output): every band equals the same band warped alone (a one-band source goes through the per-band path), for
2 to 4 bands, integer and floating data, with holes in the source and cells outside it."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio

from test_warp_parallel import CRS, SRC_T, _read, _source, _warp


def _single_band(data, path, dtype, nodata):
    with rasterio.open(path, "w", driver="GTiff", width=data.shape[1], height=data.shape[0], count=1, dtype=dtype,
                       crs=CRS, transform=SRC_T, nodata=nodata) as ds:
        ds.write(data, 1)


@pytest.mark.parametrize("bands,dtype,resampling", [(2, "uint8", "bilinear"), (3, "uint8", "bilinear"),
                                                    (4, "uint16", "cubic"), (3, "float32", "bilinear"),
                                                    (3, "uint8", "nearest")])
def test_bands_equal_single_band_warps(tmp_path, bands, dtype, resampling):
    nodata = None if np.dtype(dtype).kind == "f" else 0
    data = _source(tmp_path / "src.tif", dtype, bands=bands, nodata=nodata, holes=True)
    _warp(tmp_path / "src.tif", tmp_path / "all.tif", 2, resampling, overviews=False)
    together, out_nodata, _ = _read(tmp_path / "all.tif")
    assert together.shape[0] == bands

    def valid(a):  # cells with data (the nodata value, or NaN for floating outputs, marks the others)
        return ~np.isnan(a).all(axis=0) if out_nodata is None or out_nodata != out_nodata else \
            ~(a == out_nodata).all(axis=0)

    inside = valid(together)
    assert 0.2 < inside.mean() < 0.95  # cells inside and outside the source and its holes are all exercised
    for b in range(bands):
        _single_band(data[b], tmp_path / f"b{b}.tif", dtype, nodata)
        _warp(tmp_path / f"b{b}.tif", tmp_path / f"o{b}.tif", 2, resampling, overviews=False)
        alone = _read(tmp_path / f"o{b}.tif")[0]
        both = inside & valid(alone)  # (a pixel at nodata in one band only is valid with the other bands)
        assert both.mean() > 0.9 * inside.mean()
        np.testing.assert_array_equal(together[b][both], alone[0][both])
