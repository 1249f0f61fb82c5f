"""Rays of an RPC image onto a small DEM whose heights are far from the RPC's HEIGHT_OFF (ventoux: 1075 m, the
ground about 536 m): started at HEIGHT_OFF they landed beside the DEM and were lost (``ortho --rpc`` with the pair's
DSM: "DEM covers 1 %" for a DSM under about a quarter of the image); started inside the DEM's heights they reach it."""
from __future__ import annotations

import numpy as np
import pytest

pytestmark = [pytest.mark.data]


def test_rays_reach_a_small_dem_far_below_height_off(data_dir):
    from affine import Affine
    from fotogeo.crs import utm_crs_for
    from fotogeo.geometry.dem import Dem
    from fotogeo.geometry.lonlat_model import LonLatModel
    from fotogeo.io.rpc_image import image_rpc
    r = image_rpc(data_dir / "rpc" / "ventoux" / "left_image.tif").rpc
    assert r.height_off == pytest.approx(1075.0)
    crs = utm_crs_for(r.long_off, r.lat_off)
    m = LonLatModel(r.to_model(), crs)
    X, Y = m.inverse(np.array([[250.0, 250.0]] * 2), 536.0)[0, :2]
    dem = Dem(np.full((12, 20), 536.0), Affine(5.0, 0.0, X - 50.0, 0.0, -5.0, Y + 30.0), crs)
    u, v = np.meshgrid(np.linspace(230.0, 270.0, 5), np.linspace(230.0, 270.0, 5))
    px = np.column_stack([u.ravel(), v.ravel()])
    on_dem, flat = m.inverse(px, dem), m.inverse(px, 536.0)
    assert np.isfinite(on_dem).all()
    np.testing.assert_allclose(on_dem, flat, atol=1e-3)
