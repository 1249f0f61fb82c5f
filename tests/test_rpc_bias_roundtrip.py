"""rpc-bias on a Pleiades crop whose RPC is an OSSIM .geom beside it: the corrected RPC written into the output
GeoTIFF is read back by ``image_rpc`` (the reader the DSM and ortho use) and puts the GCPs where they were
measured.

GCPs: the rigorous model's location-grid nodes that fall inside the ventoux left crop (lon, lat at two
altitudes, their crop pixel from the grid's geotransform and the crop's window), moved by a known image bias.
"""
import shutil

import numpy as np
import pytest
import rasterio

pytest.importorskip("geopandas")

GRID = "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif"
BIAS = np.array([2.3, -1.7])  # col, row


def _gcps(v, path, bias=BIAS, affine=None, within=500, read=None):
    """The grid nodes whose crop pixel (+ ``bias``) lies in ``0..within``; ``read``: how their pixels were read."""
    import geopandas as gpd
    import shapely
    with rasterio.open(v / GRID) as ds:
        a, t = ds.read(), ds.transform
    with rasterio.open(v / "left_image.tif") as ds:
        w = ds.transform
    r, c = np.mgrid[0:a.shape[1], 0:a.shape[2]]
    x, y = t * (c.ravel(), r.ravel())
    px = np.column_stack([x - w.c, y - w.f])  # crop pixel, corner convention
    if affine is not None:
        px = px @ affine[:, :2].T + affine[:, 2]
    rows = []
    for k, h in ((1, 485.0), (2, 1000.0)):  # bands 2-3 and 4-5
        lon, lat = a[2 * k].ravel(), a[2 * k + 1].ravel()
        for i in np.flatnonzero(np.all((px + bias > 0) & (px + bias < within), axis=1)):
            q = (px[i] + bias) if read is None else read(px[i:i + 1] + bias)[0]
            rows.append({"id": f"n{i}_{int(h)}", "col": q[0], "row": q[1], "z": h,
                         "geometry": shapely.Point(lon[i], lat[i])})
    gpd.GeoDataFrame(rows, crs="EPSG:4326").to_file(path, layer="gcps", engine="pyogrio")
    return rows


@pytest.mark.data
@pytest.mark.parametrize("method", ["shift", "affine"])
def test_corrected_rpc_reads_back(data_dir, tmp_path, method, monkeypatch):
    from fotogeo import rpc_bias
    from fotogeo.io.rpc_image import image_rpc

    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    for f in ("left_image.tif", "left_image.geom"):
        shutil.copy(v / f, tmp_path)
    image = tmp_path / "left_image.tif"
    affine = np.array([[1.0005, 0.0003, 0.0], [-0.0002, 0.9996, 0.0]]) if method == "affine" else None
    rows = _gcps(v, tmp_path / "gcps.gpkg", affine=affine)
    assert len(rows) >= 12
    out = tmp_path / "left_corrected.tif"
    rep = rpc_bias(image, tmp_path / "gcps.gpkg", out, method=method)
    assert rep["control"]["before"]["rms_xy"] > 2.0
    assert rep["control"]["after"]["rms_xy"] < 0.01
    back = image_rpc(out)  # the output's GDAL RPC tags, in the crop's own pixels
    assert back.source == "GDAL RPC metadata" and back.product_window is None
    g = np.array([[r["geometry"].x, r["geometry"].y, r["z"]] for r in rows])
    measured = np.array([[r["col"], r["row"]] for r in rows])
    assert np.abs(back.rpc.to_model().forward(g) - measured).max() < 0.01
    assert np.abs(image_rpc(image).rpc.to_model().forward(g) - measured).max() > 2.0  # the input is untouched
