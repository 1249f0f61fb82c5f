"""RPC readers, one per format, against rpcm 1.4.10, GDAL and the Pleiades rigorous model.

Pixel conventions: every reader returns RPC00B (centre of the first pixel (0, 0), as rpcm and GDAL's RPC
metadata); ``Rpc.to_model`` is fotogeo's corner convention (+0.5), the convention of GDAL's RPC transformer.
"""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError
from fotogeo.io.rpc import read_rpc, rpc_from_raster, write_rpc_geotiff
from fotogeo.io.rpc_image import image_rpc, sidecar_rpc_files

# (lon, lat, h, col, row): col/row computed with rpcm 1.4.10, ``rpcm.rpc_from_rpc_file(f).projection(lon, lat,
# h)`` (rpcm's pixels: centre of the first pixel (0, 0)); the ground points are rpcm's localisations of pixels
# spread over each image at heights across its RPC's height range
RPCM = {
    "rpc_IKONOS.txt": [
        (-56.22826954, -34.93919129, -13.0, 1266.80034, 1024.799624),
        (-56.17212011, -34.90302106, 28.0, 6333.999918, 5124.000038),
        (-56.17919885, -34.86656473, 60.8, 10134.399871, 3586.799962),
        (-56.13702265, -34.92147056, 101.8, 5067.199564, 8710.79986),
    ],
    "rpc_PLANET_L1A.txt": [
        (151.76920869, -32.87300158, -1224.5, 256.079834, 108.079655),
        (151.75892341, -32.86906067, 31.0, 1280.400063, 540.399887),
        (151.75116941, -32.87018758, 1035.4, 2048.640199, 378.279938),
        (151.76129454, -32.86571847, 2290.9, 1024.319672, 918.679991),
    ],
    "rpc_PLANET_L1B.txt": [
        (151.76920869, -32.87300158, -1224.5, 319.999761, 134.999495),
        (151.75892341, -32.86906067, 31.0, 1599.999922, 674.999489),
        (151.75116941, -32.87018758, 1035.4, 2559.999998, 472.499663),
        (151.76129454, -32.86571847, 2290.9, 1279.999465, 1147.49936),
    ],
    "rpc_PLEIADES.xml": [
        (-56.26103364, -34.79667575, 30.0, 3999.901697, 3617.499569),
        (-56.16960972, -34.86270695, 70.0, 19999.49943, 18087.500518),
        (-56.10111403, -34.83587232, 102.0, 31999.198483, 12661.250954),
        (-56.19242417, -34.92241368, 142.0, 15999.60001, 30748.750735),
    ],
    "rpc_SPOT6.xml": [
        (-72.40536243, 18.71519026, 250.0, 2194.301493, 2476.697618),
        (-72.2677763, 18.5752812, 500.0, 10975.512405, 12387.497162),
        (-72.16567848, 18.6310119, 700.0, 17561.404328, 8670.947271),
        (-72.30079326, 18.449992, 950.0, 8780.209936, 21059.447185),
    ],
    "rpc_WV2.xml": [
        (-0.37648696, 45.69534363, -153.5, 2692.800989, 1385.600697),
        (-0.32480076, 45.65437821, 97.0, 14104.000606, 10108.000821),
        (-0.28604925, 45.66772961, 297.4, 22662.399843, 6837.100615),
        (-0.33706739, 45.61697588, 547.9, 11251.200548, 17740.099927),
    ],
    "20191015_073816_ssc1d3_0011_basic_l1a_panchromatic_dn_RPC.TXT": [
        (49.6690626, 25.92841237, 3287.57, 1293.515301, 539.486503),
        (49.68488734, 25.92828872, 7174.79, 2053.793462, 377.403991),
        (49.68642725, 25.92251913, 12033.8, 1040.089966, 917.680716),
    ],
}
VENTOUX_LEFT = "RPC_PHR1B_P_201308051042194_SEN_690908101-001.XML"
ALTITUDES = (-100.0, 485.0, 1000.0, 2000.0, 3000.0)  # the grids' LG_ALTITUDE_B0, B2, … (gdalinfo)


@pytest.mark.data
@pytest.mark.parametrize("name", sorted(RPCM))
def test_projects_as_rpcm(data_dir, name):
    ref = np.array(RPCM[name])
    rpc = read_rpc(data_dir / "rpc" / "rpcm" / name)
    assert np.abs(rpc.project(*ref[:, :3].T) - ref[:, 3:]).max() < 1e-5
    # fotogeo's corner convention: half a pixel more
    assert np.abs(rpc.to_model().forward(ref[:, :3]) - (ref[:, 3:] + 0.5)).max() < 1e-5


@pytest.mark.data
def test_unsupported_xml_refused(data_dir):
    path = data_dir / "rpc" / "rpcm" / "rpc_unsupported.xml"
    with pytest.raises(InputError, match="unsupported RPC XML") as info:
        read_rpc(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def _grid(path):
    """(lon, lat, h) of every node of a shareloc location grid at every altitude, and its full-product pixel
    (corner convention): node (i, j) is the geotransform applied to (j, i)."""
    with rasterio.open(path) as ds:
        a, t = ds.read(), ds.transform
    rows, cols = np.mgrid[0:a.shape[1], 0:a.shape[2]]
    x, y = t * (cols.ravel(), rows.ravel())
    llh = np.vstack([np.column_stack([a[2 * k].ravel(), a[2 * k + 1].ravel(), np.full(x.size, h)])
                     for k, h in enumerate(ALTITUDES)])
    return llh, np.tile(np.column_stack([x, y]), (len(ALTITUDES), 1))


@pytest.mark.data
@pytest.mark.parametrize("grid, rpc_file", [
    ("GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif", VENTOUX_LEFT),
    ("GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif", "left_image.geom"),
    ("GRID_PHR1B_P_201308051042523_SEN_690908101-002.tif", "right_image.geom"),
])
def test_pleiades_rpc_on_rigorous_grid(data_dir, grid, rpc_file):
    """The DIMAP RPC (1-based, read minus 1) and OSSIM's .geom of the same product land on the rigorous model's
    location grid in the corner convention; read as they are, the DIMAP offsets were one pixel off."""
    v = data_dir / "rpc" / "ventoux"
    llh, px = _grid(v / grid)
    d = read_rpc(v / rpc_file).to_model().forward(llh) - px
    assert np.abs(d).max() < 0.01, np.abs(d).max()


@pytest.mark.data
def test_dimap_as_gdal_reads_it(data_dir, tmp_path, monkeypatch):
    """GDAL's Pleiades metadata reader (an IMG_* raster beside its RPC_*.XML) projects like fotogeo."""
    from rasterio.transform import RPCTransformer

    monkeypatch.setenv("GDAL_PAM_ENABLED", "NO")
    v = data_dir / "rpc" / "ventoux"
    shutil.copy(v / VENTOUX_LEFT, tmp_path)
    img = tmp_path / (VENTOUX_LEFT.replace("RPC_", "IMG_")[:-4] + "_R1C1.TIF")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(img, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8") as ds:
            ds.write(np.zeros((1, 16, 16), np.uint8))
        with rasterio.open(img) as ds:
            gdal_rpcs = ds.rpcs
    assert gdal_rpcs is not None
    llh, _ = _grid(v / "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif")
    with RPCTransformer(gdal_rpcs) as tr:
        rows, cols = tr.rowcol(llh[:, 0], llh[:, 1], zs=llh[:, 2], op=lambda x: x)
    ours = read_rpc(v / VENTOUX_LEFT).to_model().forward(llh)
    assert np.abs(np.column_stack([cols, rows]) - ours).max() < 1e-3
    found = image_rpc(img)  # GDAL's metadata first
    assert found.source == "GDAL RPC metadata"
    assert np.abs(found.rpc.to_model().forward(llh) - ours).max() < 1e-6


@pytest.mark.data
@pytest.mark.parametrize("side", ["left", "right"])
def test_cropped_image_with_geom(data_dir, tmp_path, side):
    """An OTB/CARS crop (no CRS, its place in the product as geotransform) with its .geom beside it."""
    v = data_dir / "rpc" / "ventoux"
    for f in (f"{side}_image.tif", f"{side}_image.geom"):
        shutil.copy(v / f, tmp_path)
    assert sidecar_rpc_files(tmp_path / f"{side}_image.tif") == [tmp_path / f"{side}_image.geom"]
    found = image_rpc(tmp_path / f"{side}_image.tif")
    with rasterio.open(v / f"{side}_image.tif") as ds:
        t = ds.transform
    assert found.product_window == (1.0, t.c, 1.0, t.f) and found.source.endswith(".geom")
    grid = {"left": "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif",
            "right": "GRID_PHR1B_P_201308051042523_SEN_690908101-002.tif"}[side]
    llh, px = _grid(v / grid)
    inside = np.all((px >= [t.c, t.f]) & (px < [t.c + 500, t.f + 500]), axis=1)
    assert inside.sum() >= 9
    d = found.rpc.to_model().forward(llh[inside]) - (px[inside] - [t.c, t.f])
    assert np.abs(d).max() < 0.01


def test_product_window_is_exact():
    from fotogeo.io.rpc_image import in_window
    from fotogeo.orientation.rpc import Rpc

    rng = np.random.default_rng(3)
    num = lambda: np.concatenate([[0.01], rng.normal(0, 1, 3), rng.normal(0, 1e-3, 16)])  # noqa: E731
    den = lambda: np.concatenate([[1.0], rng.normal(0, 1e-3, 19)])  # noqa: E731
    rpc = Rpc(900.5, 1200.5, 45.0, 5.0, 500.0, 1000.0, 1300.0, 0.05, 0.07, 500.0, num(), den(), num(), den())
    g = np.column_stack([5.0 + rng.uniform(-0.05, 0.05, 20), 45.0 + rng.uniform(-0.04, 0.04, 20),
                         rng.uniform(0, 1000, 20)])
    full = rpc.to_model().forward(g)  # corner convention, full product
    sub = in_window(rpc, 2.0, 100.0, 2.0, 37.0).to_model().forward(g)  # a 1/2-resolution crop
    assert np.allclose(sub, (full - [100.0, 37.0]) / 2.0, atol=1e-9)


@pytest.mark.data
def test_rpb_and_geotiff_tags(data_dir, tmp_path):
    """WorldView-2's RPC written as an .RPB and as GeoTIFF RPC tags reads back identically (rpcm's numbers)."""
    rpc = read_rpc(data_dir / "rpc" / "rpcm" / "rpc_WV2.xml")
    ref = np.array(RPCM["rpc_WV2.xml"])
    lines = ['satId = "WV02";', 'SpecId = "RPC00B";', "BEGIN_GROUP = IMAGE"]
    for key, attr in (("lineOffset", "line_off"), ("sampOffset", "samp_off"), ("latOffset", "lat_off"),
                      ("longOffset", "long_off"), ("heightOffset", "height_off"), ("lineScale", "line_scale"),
                      ("sampScale", "samp_scale"), ("latScale", "lat_scale"), ("longScale", "long_scale"),
                      ("heightScale", "height_scale")):
        lines.append(f"\t{key} = {getattr(rpc, attr):+.15g};")
    for key, attr in (("lineNumCoef", "line_num"), ("lineDenCoef", "line_den"), ("sampNumCoef", "samp_num"),
                      ("sampDenCoef", "samp_den")):
        vals = ",\n\t\t\t".join(f"{v:+.15E}" for v in getattr(rpc, attr))
        lines.append(f"\t{key} = (\n\t\t\t{vals});")
    lines += ["END_GROUP = IMAGE", "END;"]
    (tmp_path / "wv2.RPB").write_text("\n".join(lines) + "\n")
    rpb = read_rpc(tmp_path / "wv2.RPB")
    assert np.abs(rpb.project(*ref[:, :3].T) - ref[:, 3:]).max() < 1e-5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(tmp_path / "src.tif", "w", driver="GTiff", width=8, height=8, count=1,
                           dtype="uint8") as ds:
            ds.write(np.zeros((1, 8, 8), np.uint8))
    write_rpc_geotiff(tmp_path / "src.tif", tmp_path / "wv2.tif", rpc)
    tags = rpc_from_raster(tmp_path / "wv2.tif")
    assert np.abs(tags.project(*ref[:, :3].T) - ref[:, 3:]).max() < 1e-5


@pytest.mark.data
def test_ossim_geom_reads_like_dimap(data_dir):
    v = data_dir / "rpc" / "ventoux"
    a, b = read_rpc(v / "left_image.geom"), read_rpc(v / VENTOUX_LEFT)
    g = np.array([[5.19, 44.21, 500.0], [5.30, 44.10, 1500.0]])
    assert np.abs(a.project(*g.T) - b.project(*g.T)).max() < 1e-6


@pytest.mark.data
def test_dimap_v3_first_col(data_dir, tmp_path):
    """Pleiades Neo (DIMAP v3): GroundtoImage_Values; the first pixel's centre from ImagetoGround_Validity_Domain
    (GDAL's rule), 1 when absent."""
    text = (data_dir / "rpc" / "rpcm" / "rpc_PLEIADES.xml").read_text()
    v2 = read_rpc(data_dir / "rpc" / "rpcm" / "rpc_PLEIADES.xml")
    v3 = text.replace("Inverse_Model>", "GroundtoImage_Values>").replace("PHR_SENSOR", "PNEO_SENSOR")
    (tmp_path / "a.xml").write_text(v3)
    assert read_rpc(tmp_path / "a.xml").line_off == v2.line_off
    domain = "<ImagetoGround_Validity_Domain><FIRST_ROW>0</FIRST_ROW><FIRST_COL>0</FIRST_COL>" \
             "</ImagetoGround_Validity_Domain>"
    (tmp_path / "b.xml").write_text(v3.replace("<RFM_Validity>", "<RFM_Validity>" + domain))
    b = read_rpc(tmp_path / "b.xml")
    assert (b.line_off, b.samp_off) == (v2.line_off + 1, v2.samp_off + 1)


@pytest.mark.data
@pytest.mark.parametrize("edit, expected", [
    (("polynomial_format:  B", "polynomial_format:  A"), "polynomial_format A is not supported"),
    (("adjustment_0.adj_param_0.parameter:  0", "adjustment_0.adj_param_0.parameter:  3.5"),
     "adjustment intrack_offset = 3.5"),
    (("line_num_coeff_07:", "line_num_coeff_07: x"), "non-numeric"),
])
def test_ossim_geom_refused(data_dir, tmp_path, edit, expected):
    text = (data_dir / "rpc" / "ventoux" / "left_image.geom").read_text()
    assert edit[0] in text
    path = tmp_path / "x.geom"
    path.write_text(text.replace(edit[0], edit[1]))
    with pytest.raises(InputError, match=expected) as info:
        read_rpc(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.data
def test_image_rpc_refusals(data_dir, tmp_path):
    with pytest.raises(InputError, match="has no RPC"):
        image_rpc(data_dir / "landsat_rgb" / "RGB.byte.tif")
    with pytest.raises(InputError, match="is georeferenced"):
        image_rpc(data_dir / "landsat_rgb" / "RGB.byte.tif", data_dir / "rpc" / "ventoux" / "left_image.geom")
    (tmp_path / "x.xml").write_text("<isd><IMD/></isd>")
    with pytest.raises(InputError, match="no RPB/IMAGE"):
        read_rpc(tmp_path / "x.xml")


@pytest.mark.data
def test_ortho_reads_a_crop_with_its_geom(data_dir, tmp_path):
    """``ortho --rpc`` on an OTB/CARS crop: the .geom beside it, moved into the crop's pixels (UTM from the RPC)."""
    from fotogeo.crs import to_lonlat
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models

    v = data_dir / "rpc" / "ventoux"
    for f in ("left_image.tif", "left_image.geom"):
        shutil.copy(v / f, tmp_path)
    img = str(tmp_path / "left_image.tif")
    crs, why = map_crs("auto", None, None, [img], True)
    assert "UTM" in why and crs.to_epsg() == 32631
    model = image_models([img], crs, rpc=True)[0].model
    llh, px = _grid(v / "GRID_PHR1B_P_201308051042194_SEN_690908101-001.tif")
    inside = np.all((px >= 5000) & (px < 5500), axis=1)
    from pyproj import Transformer
    xy = np.column_stack(Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(*llh[inside, :2].T))
    assert np.allclose(to_lonlat(crs, xy), llh[inside, :2], atol=1e-9)
    d = model.forward(np.column_stack([xy, llh[inside, 2]])) - (px[inside] - 5000.0)
    assert np.abs(d).max() < 0.01


@pytest.mark.data
@pytest.mark.parametrize("name, edit, expected", [
    ("rpc_WV2.xml", ("1.594159000000000e-03 ", ""), "LINE_NUM_COEFF must have 20 values; got 19"),
    ("rpc_WV2.xml", ("1.594159000000000e-03", "abc"), "LINENUMCOEF holds a non-numeric value"),
    ("rpc_WV2.xml", ("<SPECID>RPC00B</SPECID>", "<SPECID>RPC00A</SPECID>"), "SPECID RPC00A is not supported"),
    ("rpc_WV2.xml", ("<LINEOFFSET>10108</LINEOFFSET>", ""), "missing RPC00B key LINE_OFF"),
    ("rpc_PLEIADES.xml", ("<RFM_Validity>", "<RFM_Validity><ImagetoGround_Validity_Domain><FIRST_COL>x"
                          "</FIRST_COL></ImagetoGround_Validity_Domain>"), None),
])
def test_xml_refused(data_dir, tmp_path, name, edit, expected):
    text = (data_dir / "rpc" / "rpcm" / name).read_text()
    assert edit[0] in text
    if expected is None:  # DIMAP v3 with a damaged FIRST_COL
        text = text.replace("Inverse_Model>", "GroundtoImage_Values>")
        expected = "FIRST_COL 'x' is not a number"
    path = tmp_path / name
    path.write_text(text.replace(edit[0], edit[1]))
    with pytest.raises(InputError, match=expected) as info:
        read_rpc(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("text, expected", [
    ("lineOffset = 5;\nsampOffset = (1, 2;\n", "sampOffset = '\\(1, 2' is not a single value"),
    ("lineOffset = 5;\nlineNumCoef = 3;\n", "lineNumCoef = '3' is not a list"),
    ("lineOffset = 5;\n", "missing RPC00B key SAMP_OFF"),
])
def test_rpb_refused(tmp_path, text, expected):
    path = tmp_path / "x.RPB"
    path.write_text(text)
    with pytest.raises(InputError, match=expected) as info:
        read_rpc(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def _tagged(path, rpc, transform=None):
    """A 16² uint8 GeoTIFF with ``rpc`` as GDAL RPC tags and, when given, a CRS-less geotransform."""
    kw = {} if transform is None else {"transform": transform}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path, "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8", **kw) as ds:
            ds.write(np.zeros((1, 16, 16), np.uint8))
            ds.update_tags(ns="RPC", **rpc.to_gdal_metadata())
    return path


@pytest.mark.data
def test_rpc_tags_beside_a_pixel_window_are_refused(data_dir, tmp_path):
    """GDAL RPC tags with a CRS-less window geotransform (col_off, 1, 0, row_off, 0, 1): GDAL's RPC transformer
    ignores the geotransform, and a cut-out that kept the full product's tags was read 60 px (here) off without a
    word — on the rendered pair a DSM 20.7 m RMSE from its truth, placed at the product's origin. Refused in one line
    naming the image and both fixes; the same tags without a geotransform are read as GDAL reads them."""
    from affine import Affine
    from click.testing import CliRunner

    from fotogeo.cli import main
    rpc = read_rpc(data_dir / "rpc" / "ventoux" / "left_image.geom")
    plain = image_rpc(_tagged(tmp_path / "plain.tif", rpc))
    g = np.array([[5.19, 44.21, 500.0], [5.30, 44.10, 1500.0]])
    assert plain.source == "GDAL RPC metadata" and np.abs(plain.rpc.project(*g.T) - rpc.project(*g.T)).max() < 1e-6
    crops = [_tagged(tmp_path / f"crop{i}.tif", rpc, Affine(1, 0, 60, 0, 1, 40)) for i in (1, 2)]
    with pytest.raises(InputError, match=r"crop1.tif' has GDAL RPC tags and a geotransform without a CRS .*\(60, 40\)"
                                         r".*gdal_edit.py -unsetgt crop1.tif.*gdal_translate -srcwin") as info:
        image_rpc(crops[0])
    assert "\n" not in str(info.value)
    out = tmp_path / "d.tif"
    r = CliRunner().invoke(main, ["dsm", *map(str, crops), "--rpc", "-o", str(out)])
    assert r.exit_code == 1 and r.output.strip().startswith("Error: image") and "crop1.tif" in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1 and not out.exists()


def test_rpc_geotiff_of_a_crop_drops_its_window(tmp_path):
    """write_rpc_geotiff writes an RPC of the copy's own pixels: a crop's CRS-less window geotransform is dropped
    (beside the tags it would be refused as ambiguous), so fotogeo's own output reads back."""
    from affine import Affine

    from fotogeo.orientation.rpc import Rpc
    rng = np.random.default_rng(3)
    num = lambda: np.concatenate([[0.01], rng.normal(0, 1, 3), rng.normal(0, 1e-3, 16)])  # noqa: E731
    den = lambda: np.concatenate([[1.0], rng.normal(0, 1e-3, 19)])  # noqa: E731
    rpc = Rpc(900.5, 1200.5, 45.0, 5.0, 500.0, 1000.0, 1300.0, 0.05, 0.07, 500.0, num(), den(), num(), den())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(tmp_path / "crop.tif", "w", driver="GTiff", width=16, height=16, count=1, dtype="uint8",
                           transform=Affine(1, 0, 5000, 0, 1, 5000)) as ds:
            ds.write(np.zeros((1, 16, 16), np.uint8))
    write_rpc_geotiff(tmp_path / "crop.tif", tmp_path / "out.tif", rpc)
    back = image_rpc(tmp_path / "out.tif")
    assert back.source == "GDAL RPC metadata" and back.product_window is None
    with rasterio.open(tmp_path / "out.tif") as ds:
        assert ds.transform.is_identity and ds.crs is None
    assert np.allclose(back.rpc.project(5.0, 45.0, 500.0), rpc.project(5.0, 45.0, 500.0))
