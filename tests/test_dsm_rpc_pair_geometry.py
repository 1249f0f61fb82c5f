"""The pair measures of ``dsm --rpc`` (base-to-height ratio, the angle the rays meet at, the views' difference) do
not depend on ``--crs``: a projection far from the scene (its scale, its planimetry unlike the heights' metres)
once read the ventoux pair as B/H 0.42, 24 degrees under UTM 10N and refused it under the Antarctic polar
stereographic as "the views differ too much" (0.35, 20 degrees under its own UTM zone)."""
from __future__ import annotations

import pytest

from fotogeo.tools.dsm import rpc_pairs, rpc_tool

CRSS = ("EPSG:32631", "EPSG:2154", "EPSG:3857", "EPSG:32610", "EPSG:3031")


@pytest.mark.data
def test_the_pair_measures_the_same_under_any_crs(data_dir):
    v = data_dir / "rpc" / "ventoux"
    images = [v / "left_image.tif", v / "right_image.tif"]
    got = {}
    for crs in CRSS:
        ims, _, _ = rpc_tool.rpc_images(images, crs, None)
        zlo, zhi = rpc_pairs.rpc_height_range(ims)
        (p,) = rpc_tool._choose(ims, [im.name for im in ims], zlo, zhi, None)  # refused: InputError
        assert p.kept, (crs, p.reason)
        got[crs] = (p.base_height, p.convergence, p.view_angle)
    ref = got["EPSG:32631"]
    assert 0.3 < ref[0] < 0.4 and 15 < ref[1] < 25
    for crs, m in got.items():
        for a, b in zip(m, ref):
            assert a == pytest.approx(b, rel=0.01), (crs, m, ref)
