"""RPC00B export: an RFM fitted in lon/lat/h, written as GDAL RPC metadata, used by GDAL."""
from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.errors import InputError, OutputError
from fotogeo.models import MODELS
from fotogeo.orientation.rpc import Rpc, frame_rpc
from fotogeo.io.rpc import read_rpc, write_rpc_geotiff

NGI_CRS = "+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84"
FRAME = "3324c_2015_1004_05_0182"


@pytest.fixture(scope="module")
def ngi_rpc(data_dir):
    ngi = data_dir / "ngi"
    frame, dem = load_ngi_frame(ngi, FRAME), read_dem(ngi / "dem.tif")
    rpc, model = frame_rpc(frame, NGI_CRS, dem.z_range)
    rng = np.random.default_rng(5)
    px = rng.uniform([0, 0], [640, 1152], (300, 2))
    P = frame.pixel_to_world(px, dem)
    from pyproj import Transformer

    lon, lat = Transformer.from_crs(NGI_CRS, "EPSG:4326", always_xy=True).transform(P[:, 0], P[:, 1])
    return rpc, model, np.column_stack([lon, lat, P[:, 2]]), px


@pytest.mark.data
def test_rpc_round_trip_through_model(ngi_rpc):
    rpc, model, llh, px = ngi_rpc
    assert np.abs(model.forward(llh) - px).max() < 0.01
    assert np.abs(rpc.to_model().forward(llh) - px).max() < 0.01  # corner convention both ways
    back = Rpc.from_model(rpc.to_model())
    assert np.allclose(back.project(*llh.T), rpc.project(*llh.T), atol=1e-9)
    with pytest.raises(InputError, match="ground -> image"):
        Rpc.from_model(MODELS["rfm-i2g"].estimate(np.column_stack([px, llh[:, 2]]), llh[:, :2]))


@pytest.mark.data
def test_gdaltransform_reproduces_our_projection(ngi_rpc, data_dir, tmp_path):
    if shutil.which("gdaltransform") is None:
        pytest.skip("gdaltransform not installed (Debian package gdal-bin)")
    rpc, _, llh, px = ngi_rpc
    out = write_rpc_geotiff(data_dir / "ngi" / "frames" / f"{FRAME}_RGB.tif", tmp_path / "rpc.tif", rpc)
    text = "".join(f"{a:.12f} {b:.12f} {c:.6f}\n" for a, b, c in llh)
    res = subprocess.run(["gdaltransform", "-rpc", "-i", str(out)], input=text, capture_output=True,
                         text=True, check=True)
    got = np.array([[float(v) for v in line.split()[:2]] for line in res.stdout.splitlines()])
    assert got.shape == px.shape
    assert np.abs(got - px).max() < 0.01  # pixels, GDAL's corner convention
    # the GeoTIFF's RPC reads back as the same model
    import rasterio

    with rasterio.open(out) as ds:
        md = ds.tags(ns="RPC")
    assert float(md["LINE_OFF"]) == pytest.approx(rpc.line_off)
    with pytest.raises(OutputError, match="exists"):
        write_rpc_geotiff(data_dir / "ngi" / "frames" / f"{FRAME}_RGB.tif", out, rpc)
    assert not list(tmp_path.glob(".*part*"))


@pytest.mark.data
def test_vendor_rpc_matches_gdal(data_dir, tmp_path):
    """Our RPC evaluation + 0.5 px equals GDAL's RPC transformer on a vendor file."""
    gdal = pytest.importorskip("osgeo.gdal", reason="needs GDAL's Python bindings (Debian python3-gdal)")

    rpc = read_rpc(data_dir / "rpc" / "rpcm" / "rpc_IKONOS.txt")
    ds = gdal.GetDriverByName("GTiff").Create(str(tmp_path / "v.tif"), 10, 10, 1)
    ds.SetMetadata(rpc.to_gdal_metadata(), "RPC")
    ds = None
    tr = gdal.Transformer(gdal.Open(str(tmp_path / "v.tif")), None, ["METHOD=RPC"])
    pts = [(rpc.long_off + 0.01, rpc.lat_off - 0.02, 50.0), (rpc.long_off - 0.03, rpc.lat_off + 0.01, 0.0)]
    ok_pts = tr.TransformPoints(1, pts)
    gdal_px = np.array([p[:2] for p in ok_pts[0]])
    ours = rpc.to_model().forward(np.array(pts))
    assert np.abs(gdal_px - ours).max() < 1e-6
