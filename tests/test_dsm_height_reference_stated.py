"""A DSM states its heights' reference in its files: an RPC DSM (ellipsoidal heights) has a point cloud whose CRS
is 3-D (its third axis the ellipsoidal height) and a GeoTIFF whose ``HEIGHT_REFERENCE`` metadata item says
``ellipsoid`` (its CRS stays 2-D: GeoTIFF has no projected CRS with an ellipsoidal height and GDAL writes none);
``ortho --dem`` and ``dsm --dem`` read it back ("DEM heights: ellipsoid (from its metadata)") instead of warning
that the DEM does not state its reference.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

from fotogeo.errors import FotogeoWarning


@pytest.fixture(scope="module")
def rpc_dsm(tmp_path_factory):
    from rendered_rpc_pair import render_rpc_pair

    from fotogeo.tools.dsm import dsm
    d = tmp_path_factory.mktemp("sat")
    sc = render_rpc_pair(d, 256)
    rep = dsm(sc["images"], d / "dsm.tif", rpc=True, resolution=0.7, point_cloud=d / "points.las")
    return sc, rep, d


def test_the_rpc_dsm_states_ellipsoidal_heights_in_its_files(rpc_dsm):
    import laspy

    from fotogeo.geometry.vertical import crs_height_reference
    _, rep, d = rpc_dsm
    assert rep["height_reference"] == "ellipsoid"
    with rasterio.open(d / "dsm.tif") as ds:
        assert ds.tags()["HEIGHT_REFERENCE"] == "ellipsoid" and ds.crs.to_epsg() == 32633
    las = laspy.read(d / "points.las").header.parse_crs()
    assert crs_height_reference(las) == "ellipsoid" and las.to_2d().to_epsg() == 32633
    assert las.axis_info[2].name == "Ellipsoidal height"


def test_ortho_reads_the_rpc_dsms_reference_back(rpc_dsm, tmp_path):
    from fotogeo.tools.ortho import ortho
    sc, _, d = rpc_dsm
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        rep = ortho(sc["images"][:1], tmp_path, rpc=True, dem=d / "dsm.tif")
    assert "DEM heights: ellipsoid (from its metadata)" in rep["notes"], rep["notes"]
    assert not [w for w in said if issubclass(w.category, FotogeoWarning) and "state" in str(w.message)]


def test_dsm_reads_the_rpc_dsms_reference_back(rpc_dsm, tmp_path):
    from fotogeo.tools.dsm import dsm
    sc, _, d = rpc_dsm
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        rep = dsm(sc["images"], tmp_path / "again.tif", rpc=True, resolution=0.7, dem=d / "dsm.tif")
    assert "DEM heights: ellipsoid (from its metadata)" in rep["notes"], rep["notes"]
    assert not [w for w in said if issubclass(w.category, FotogeoWarning) and "state" in str(w.message)]


def _raster(path, crs, tags):
    with rasterio.open(path, "w", driver="GTiff", width=4, height=4, count=1, dtype="float32", crs=crs,
                       transform=Affine(10, 0, 500000, 0, -10, 7000000)) as ds:
        ds.write(np.zeros((1, 4, 4), np.float32))
        ds.update_tags(**tags)
    return path


@pytest.mark.parametrize("crs,tags,expected", [
    ("EPSG:32735", {"HEIGHT_REFERENCE": "ellipsoid"}, ("ellipsoid", "metadata")),
    ("EPSG:32735", {"HEIGHT_REFERENCE": " Geoid "}, ("geoid", "metadata")),
    ("EPSG:32735", {"HEIGHT_REFERENCE": "sea level"}, (None, None)),  # not a reference fotogeo knows: unstated
    ("EPSG:32735", {}, (None, None)),
    ("EPSG:32735+5773", {"HEIGHT_REFERENCE": "ellipsoid"}, ("geoid", "CRS")),  # the CRS says it first
])
def test_the_stated_reference(tmp_path, crs, tags, expected):
    from fotogeo.io.raster import stated_height_reference
    path = _raster(tmp_path / "dem.tif", crs, tags)
    with rasterio.open(path) as ds:
        assert stated_height_reference(path, ds.crs) == expected
