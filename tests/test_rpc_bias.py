"""RPC bias compensation on the real QuickBird-2 image and its 5 surveyed GCPs."""
import json

import numpy as np
import pytest

from fotogeo.errors import InputError, RasterError
from fotogeo.orientation.bias import estimate_bias
from fotogeo.io.rpc import rpc_from_raster


def _gcps(qb2):
    fc = json.loads((qb2 / "gcps.geojson").read_text())
    g = np.array([f["geometry"]["coordinates"] for f in fc["features"]], float)
    ji = np.array([f["properties"]["ji"] for f in fc["features"]], float)
    return g, ji + 0.5  # orthority's "ji" puts pixel centres at integers: corner convention adds 0.5


def test_shift_removes_the_vendor_bias(data_dir):
    qb2 = data_dir / "qb2"
    rpc = rpc_from_raster(qb2 / "qb2_basic1b.tif")
    g, px = _gcps(qb2)
    b = estimate_bias(rpc, g, px, "shift")
    s = b.summary()
    # the data README: projecting through the vendor RPC is off by about (+3.0, +2.1) px
    np.testing.assert_allclose(-b.before.mean(axis=0), [3.0, 2.1], atol=0.1)
    assert s["rms_before_px"] > 3.0 and s["rms_after_px"] < 0.2 and s["rms_leave_one_out_px"] < 0.25
    a = estimate_bias(rpc, g, px, "affine").summary()
    assert a["rms_after_px"] <= s["rms_after_px"]  # more parameters fit the GCPs better ...
    assert a["rms_leave_one_out_px"] > s["rms_leave_one_out_px"]  # ... but predict worse with 5 GCPs


def test_bias_bad_input(data_dir, tmp_path):
    rpc = rpc_from_raster(data_dir / "qb2" / "qb2_basic1b.tif")
    with pytest.raises(InputError, match="at least 3"):
        estimate_bias(rpc, np.zeros((2, 3)), np.zeros((2, 2)), "affine")
    with pytest.raises(RasterError, match="no RPC"):
        rpc_from_raster(data_dir / "landsat_rgb" / "RGB.byte.tif")
