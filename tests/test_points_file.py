"""QGIS Georeferencer ``.points`` files: format, pixel convention, GeoPackage round trips."""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.errors import InputError, OutputError, VectorError
from fotogeo.io.points import HEADER, pixel_to_source, read_points, source_to_pixel, write_points
from fotogeo.tools.points.layers import layer_to_points, points_to_layer

gpd = pytest.importorskip("geopandas")

# As QGIS 3.26+ writes it (QgsGCPList::saveGcps): #CRS line, header, 8 columns.
QGIS_TEXT = """#CRS: PROJCRS["WGS 84 / UTM zone 35S",BASEGEOGCRS["WGS 84",DATUM["World Geodetic System 1984",ELLIPSOID["WGS 84",6378137,298.257223563,LENGTHUNIT["metre",1]]],PRIMEM["Greenwich",0,ANGLEUNIT["degree",0.0174532925199433]]],CONVERSION["UTM zone 35S",METHOD["Transverse Mercator",ID["EPSG",9807]],PARAMETER["Latitude of natural origin",0,ANGLEUNIT["degree",0.0174532925199433]],PARAMETER["Longitude of natural origin",27,ANGLEUNIT["degree",0.0174532925199433]],PARAMETER["Scale factor at natural origin",0.9996,SCALEUNIT["unity",1]],PARAMETER["False easting",500000,LENGTHUNIT["metre",1]],PARAMETER["False northing",10000000,LENGTHUNIT["metre",1]]],CS[Cartesian,2],AXIS["easting",east,ORDER[1],LENGTHUNIT["metre",1]],AXIS["northing",north,ORDER[2],LENGTHUNIT["metre",1]],ID["EPSG",32735]]
mapX,mapY,sourceX,sourceY,enable,dX,dY,residual
301234.5,6290011.25,0.5,-0.5,1,0.3,-0.4,0.5
301300,6289900.125,640,-1152,0,0,0,0
301250.75,6289950,320.25,-576.125,1,-1.5,2,2.5
"""


def test_read_qgis_file_and_pixel_convention(tmp_path):
    p = tmp_path / "a.points"
    p.write_text(QGIS_TEXT)
    gp = read_points(p)
    assert len(gp) == 3
    assert gp.crs.startswith("PROJCRS[") and 'ID["EPSG",32735]' in gp.crs
    np.testing.assert_array_equal(gp.map_xy, [[301234.5, 6290011.25], [301300, 6289900.125], [301250.75, 6289950]])
    np.testing.assert_array_equal(gp.enabled, [True, False, True])
    np.testing.assert_array_equal(gp.residual[2], [-1.5, 2.0])
    colrow = source_to_pixel(gp.source_xy)
    # the centre of the top-left pixel is (0.5, -0.5) in QGIS and (0.5, 0.5) in fotogeo/GDAL
    np.testing.assert_array_equal(colrow, [[0.5, 0.5], [640, 1152], [320.25, 576.125]])
    np.testing.assert_array_equal(pixel_to_source(colrow), gp.source_xy)


def test_read_old_formats(tmp_path):
    p = tmp_path / "old.points"
    # QGIS <= 3.24 header (pixelX/pixelY), no CRS line, a 5-column line, and the tab format
    p.write_text("mapX,mapY,pixelX,pixelY,enable,dX,dY,residual\n10,20,1.5,-2.5,1\n"
                 "30,40,3,-4,0,0,0,0\n")
    gp = read_points(p)
    assert gp.crs is None and len(gp) == 2
    np.testing.assert_array_equal(gp.enabled, [True, False])
    assert np.isnan(gp.residual[0]).all()
    t = tmp_path / "tab.points"
    t.write_text("mapX\tmapY\tpixelX\tpixelY\tenable\n10\t20\t1.5\t-2.5\t1\n")
    np.testing.assert_array_equal(read_points(t).source_xy, [[1.5, -2.5]])


def test_write_read_round_trip_exact(tmp_path, rng):
    m = rng.uniform(-1e6, 1e7, (50, 2))
    s = rng.uniform(-5000, 5000, (50, 2))
    en = rng.random(50) > 0.3
    r = rng.normal(size=(50, 2))
    p = tmp_path / "rt.points"
    write_points(p, m, s, en, r, crs="EPSG:32735")
    lines = p.read_text().splitlines()
    assert lines[0] == "#CRS: EPSG:32735" and lines[1] == HEADER and len(lines) == 52
    gp = read_points(p)
    np.testing.assert_array_equal(gp.map_xy, m)  # shortest round-trip text: bit-exact
    np.testing.assert_array_equal(gp.source_xy, s)
    np.testing.assert_array_equal(gp.enabled, en)
    np.testing.assert_array_equal(gp.residual, r)
    assert float(lines[2].split(",")[7]) == pytest.approx(np.hypot(*r[0]))


def test_georeferenced_source_convention():
    from affine import Affine
    t = Affine(30.0, 0, 100000.0, 0, -30.0, 2000000.0)
    colrow = np.array([[0.5, 0.5], [10.0, 20.0]])
    src = pixel_to_source(colrow, t)
    np.testing.assert_allclose(src, [[100015.0, 1999985.0], [100300.0, 1999400.0]])
    np.testing.assert_allclose(source_to_pixel(src, t), colrow)


def test_bad_inputs(tmp_path):
    with pytest.raises(VectorError, match="does not exist"):
        read_points(tmp_path / "nope.points")
    bad = tmp_path / "bad.points"
    bad.write_text(HEADER + "\n1,2,3\n")
    with pytest.raises(VectorError, match="line 2.*at least 4 values"):
        read_points(bad)
    bad.write_text(HEADER + "\n1,2,x,4,1\n")
    with pytest.raises(VectorError, match="line 2: not a number"):
        read_points(bad)
    bad.write_text("#CRS: EPSG:4326\n" + HEADER + "\n")
    with pytest.raises(VectorError, match="holds no points"):
        read_points(bad)
    with pytest.raises(InputError, match="map_xy has 2 points but source_xy has 1"):
        write_points(tmp_path / "x.points", [[1, 2], [3, 4]], [[1, 2]])


def test_points_to_layer_and_back(tmp_path):
    p = tmp_path / "a.points"
    p.write_text(QGIS_TEXT)
    g = tmp_path / "gcps.gpkg"
    info = points_to_layer(p, g)
    assert info["points"] == 3 and info["enabled"] == 2 and info["crs"] == "EPSG:32735"
    gdf = gpd.read_file(g, layer="gcps")
    assert gdf.crs.to_epsg() == 32735
    assert list(gdf["role"]) == ["control", "check", "control"]
    assert list(gdf["id"]) == [1, 2, 3]
    np.testing.assert_array_equal(gdf[["col", "row"]].to_numpy(), [[0.5, 0.5], [640, 1152], [320.25, 576.125]])
    np.testing.assert_array_equal(np.column_stack([gdf.geometry.x, gdf.geometry.y]), read_points(p).map_xy)
    assert gdf["z"].isna().all()
    # and back: same numbers, same enable flags, CRS kept
    q = tmp_path / "back.points"
    out = layer_to_points(g, q, layer="gcps")
    assert out["points"] == 3 and out["crs"] == "EPSG:32735"
    a, b = read_points(p), read_points(q)
    np.testing.assert_array_equal(b.map_xy, a.map_xy)
    np.testing.assert_array_equal(b.source_xy, a.source_xy)
    np.testing.assert_array_equal(b.enabled, a.enabled)
    np.testing.assert_array_equal(b.residual, a.residual)
    from pyproj import CRS
    assert CRS.from_user_input(b.crs).to_epsg() == 32735


def test_layer_to_points_orders_by_id_and_maps_roles(tmp_path):
    import shapely
    g = tmp_path / "pts.gpkg"
    gpd.GeoDataFrame({"id": [3, 1, 2], "col": [3.5, 1.5, 2.5], "row": [30.5, 10.5, 20.5],
                      "role": ["check", "control", "ignore"], "enabled": [1, 1, 1]},
                     geometry=shapely.points([[3, 30], [1, 10], [2, 20]]), crs="EPSG:4326").to_file(g, layer="x")
    q = tmp_path / "o.points"
    layer_to_points(g, q)
    gp = read_points(q)
    np.testing.assert_array_equal(gp.map_xy, [[1, 10], [2, 20], [3, 30]])
    np.testing.assert_array_equal(gp.source_xy, [[1.5, -10.5], [2.5, -20.5], [3.5, -30.5]])
    np.testing.assert_array_equal(gp.enabled, [True, False, False])
    with pytest.raises(OutputError, match="exists"):
        layer_to_points(g, q)
    layer_to_points(g, q, overwrite=True)
    gpd.GeoDataFrame({"col": [1.5, 2.5], "row": [10.5, 20.5], "role": ["control", "control"], "enabled": [1, 0]},
                     geometry=shapely.points([[1, 10], [2, 20]]), crs="EPSG:4326").to_file(g, layer="off")
    layer_to_points(g, q, layer="off", overwrite=True)  # a disabled control point: written disabled (enable 0)
    np.testing.assert_array_equal(read_points(q).enabled, [True, False])


def test_layer_errors_leave_nothing(tmp_path):
    import shapely
    g = tmp_path / "nofields.gpkg"
    gpd.GeoDataFrame({"name": ["a"]}, geometry=shapely.points([[1, 2]]), crs="EPSG:4326").to_file(g)
    with pytest.raises(VectorError, match="lacks the field.*col, row.*its fields are: name"):
        layer_to_points(g, tmp_path / "o.points")
    g2 = tmp_path / "nulls.gpkg"
    gpd.GeoDataFrame({"col": [1.0, None], "row": [1.0, 2.0]}, geometry=shapely.points([[1, 2], [3, 4]])).to_file(g2)
    with pytest.raises(VectorError, match="NULL"):
        layer_to_points(g2, tmp_path / "o.points")
    p = tmp_path / "a.points"
    p.write_text("#CRS: not-a-crs\n" + HEADER + "\n1,2,3,-4,1,0,0,0\n")
    with pytest.raises(InputError, match="not a CRS"):
        points_to_layer(p, tmp_path / "o.gpkg")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.points", "nofields.gpkg", "nulls.gpkg"]


@pytest.mark.data
def test_georeferenced_raster_and_register_tie_points(tmp_path, data_dir):
    """Source coordinates of a georeferenced raster are its map coordinates (rasterio agrees)."""
    import rasterio
    ras = data_dir / "landsat_rgb" / "RGB.byte.tif"
    with rasterio.open(ras) as ds:
        t = ds.transform
        crs = ds.crs.to_wkt()
    colrow = np.array([[0.5, 0.5], [100.25, 200.75], [790.5, 717.5]])
    src = np.array([t * tuple(c) for c in colrow])
    p = tmp_path / "geo.points"
    write_points(p, src + 1000.0, src, crs=crs)
    g = tmp_path / "geo.gpkg"
    info = points_to_layer(p, g, raster=ras)
    assert info["source_convention"] == "georeferenced raster"
    gdf = gpd.read_file(g)
    np.testing.assert_allclose(gdf[["col", "row"]].to_numpy(), colrow, atol=1e-6)
    # a register-style tie_points layer (target_col/target_row) converts directly
    import shapely
    tp = tmp_path / "tp.gpkg"
    gpd.GeoDataFrame({"id": [0, 1], "role": ["control", "check"], "target_col": [5.5, 6.5],
                      "target_row": [7.5, 8.5]}, geometry=shapely.points([[1, 2], [3, 4]]),
                     crs="EPSG:32735").to_file(tp, layer="tie_points")
    q = tmp_path / "tp.points"
    layer_to_points(tp, q, layer="tie_points")
    gp = read_points(q)
    np.testing.assert_array_equal(gp.source_xy, [[5.5, -7.5], [6.5, -8.5]])
    np.testing.assert_array_equal(gp.enabled, [True, False])


def test_a_layer_named_for_another_format_is_refused(tmp_path):
    """points-to-layer -o gcps.shp wrote a GeoPackage named .shp on main (exit 0), which a Shapefile reader
    cannot open; refused before the points are read."""
    p = tmp_path / "a.points"
    p.write_text("#CRS: EPSG:32735\n" + HEADER + "\n500100.5,6200200.25,120.5,-80.25,1,0,0,0\n")
    with pytest.raises(OutputError, match="fotogeo writes it as GeoPackage; give a file name ending in .gpkg"):
        points_to_layer(p, tmp_path / "gcps.shp")
    assert not (tmp_path / "gcps.shp").exists()
