"""Property-based fuzzing of the text readers (hypothesis): any input gives a valid result or a
:class:`~fotogeo.errors.FotogeoError` with a one-line message — never another exception.

Inputs are built from the readers' own vocabulary (headers, keys, numbers, ``nan``, ``inf``,
separators, comments) mixed with arbitrary text, so that most examples get past the first
line. Each test is derandomised with a fixed number of examples (the whole module runs in
about 20 s; ``FOTOGEO_FUZZ_EXAMPLES=1000`` hunts longer, 2 min) and checks what a valid
result must satisfy: finite numbers, matching lengths.
"""
from __future__ import annotations

import math
import os

import numpy as np
import pytest

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fotogeo.errors import FotogeoError

#: examples per reader; FOTOGEO_FUZZ_EXAMPLES=5000 for a longer hunt
FUZZ = settings(max_examples=int(os.environ.get("FOTOGEO_FUZZ_EXAMPLES", 150)), derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

NUMBERS = st.one_of(st.integers(-10 ** 6, 10 ** 6).map(str), st.floats(allow_nan=True).map(repr),
                    st.sampled_from(["nan", "inf", "-inf", "1e999", "", " ", "0", "1", "2", "-0", "1_0", "0x10",
                                     "abc", "1,5", "NULL", "None", "true"]))
TEXT = st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=30)


def _line(values) -> str:
    return ",".join(values)


def _check_message(error: FotogeoError):
    assert "\n" not in str(error) and str(error), repr(error)


# -- QGIS .points --------------------------------------------------------------------------

POINT_LINES = st.lists(st.one_of(
    st.lists(NUMBERS, min_size=0, max_size=10).map(_line),
    st.sampled_from(["mapX,mapY,sourceX,sourceY,enable,dX,dY,residual", "mapX,mapY,pixelX,pixelY,enable",
                     "#CRS: EPSG:32635", "#CRS:", "# comment", "", "\t", "MAPX\tMAPY\tSOURCEX\tSOURCEY"]),
    TEXT), max_size=8)


@FUZZ
@given(lines=POINT_LINES)
def test_points_reader(tmp_path_factory, lines):
    from fotogeo.io.points import read_points
    path = tmp_path_factory.mktemp("pts") / "x.points"
    path.write_text("\n".join(lines), encoding="utf-8", errors="surrogatepass")
    try:
        gp = read_points(path)
    except FotogeoError as e:
        _check_message(e)
        return
    n = len(gp)
    assert n > 0 and gp.map_xy.shape == (n, 2) and gp.source_xy.shape == (n, 2) and gp.enabled.shape == (n,)
    assert np.isfinite(gp.map_xy).all() and np.isfinite(gp.source_xy).all()


@FUZZ
@given(raw=st.binary(max_size=200))
def test_points_reader_bytes(tmp_path_factory, raw):
    from fotogeo.io.points import read_points
    path = tmp_path_factory.mktemp("ptsb") / "x.points"
    path.write_bytes(raw)
    try:
        read_points(path)
    except FotogeoError as e:
        _check_message(e)


# -- CSV GCP tables and GCP layers ----------------------------------------------------------

CSV_HEADERS = st.sampled_from(["id,x,y,col,row", "x,y,col,row,z,role", "X,Y,COL,ROW", "mapx,mapy,col,row,id",
                               "id,x,y,col", "lon,lat,col,row,role,role", "x,x,col,row", ""])


@FUZZ
@given(header=CSV_HEADERS, rows=st.lists(st.lists(st.one_of(NUMBERS, st.sampled_from(["control", "check", "blunder",
                                                                                      "G1", "x"])),
                                                   min_size=0, max_size=7).map(_line), max_size=8),
       crs=st.sampled_from(["EPSG:32635", "EPSG:4326", "nonsense", "EPSG:4978"]))
def test_csv_gcp_reader(tmp_path_factory, header, rows, crs):
    from fotogeo.io.gcps import read_gcps
    path = tmp_path_factory.mktemp("csv") / "g.csv"
    path.write_text("\n".join([header, *rows]) + "\n")
    try:
        g = read_gcps(path, crs=crs)
    except FotogeoError as e:
        _check_message(e)
        return
    assert len(g) > 0 and np.isfinite(g.ground[:, :2]).all() and np.isfinite(g.pixel).all()
    assert set(g.role) <= {"control", "check", "blunder"} and len(set(g.ids)) == len(g)


@FUZZ
@given(values=st.lists(st.tuples(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.none()),
                                 st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.none(),
                                           st.sampled_from(["12.5", "abc", ""])),
                                 st.booleans()), min_size=0, max_size=6))
def test_gcp_layer_reader(tmp_path_factory, values):
    import geopandas as gpd
    import shapely
    from fotogeo.io.gcps import read_gcps
    path = tmp_path_factory.mktemp("layer") / "g.gpkg"
    geoms = [shapely.Point(500000 + i, 4000000 + i) if has_geom else None for i, (_, _, has_geom) in enumerate(values)]
    cols = [c for c, _, _ in values]
    rows = [r for _, r, _ in values]
    rows = rows if all(isinstance(r, (float, type(None))) for r in rows) else [str(r) for r in rows]
    gpd.GeoDataFrame({"col": cols, "row": rows}, geometry=geoms, crs="EPSG:32635").to_file(path, driver="GPKG")
    try:
        g = read_gcps(path)
    except FotogeoError as e:
        _check_message(e)
        return
    assert np.isfinite(g.pixel).all() and np.isfinite(g.ground[:, :2]).all()


# -- RPC text --------------------------------------------------------------------------------

RPC_KEYS = ["LINE_OFF", "SAMP_OFF", "LAT_OFF", "LONG_OFF", "HEIGHT_OFF", "LINE_SCALE", "SAMP_SCALE", "LAT_SCALE",
            "LONG_SCALE", "HEIGHT_SCALE"] + [f"{k}_{i}" for k in ("LINE_NUM_COEFF", "LINE_DEN_COEFF",
                                                               "SAMP_NUM_COEFF", "SAMP_DEN_COEFF") for i in range(1, 21)]


@FUZZ
@given(bad=st.dictionaries(st.sampled_from(RPC_KEYS), st.one_of(NUMBERS, TEXT), max_size=6),
       drop=st.sets(st.sampled_from(RPC_KEYS), max_size=3), noise=st.lists(TEXT, max_size=3))
def test_rpc_text_reader(tmp_path_factory, bad, drop, noise):
    from fotogeo.io.rpc import read_rpc
    values = {k: "1.0" for k in RPC_KEYS} | bad
    lines = [f"{k}: {v} pixels" for k, v in values.items() if k not in drop] + noise
    path = tmp_path_factory.mktemp("rpc") / "x_RPC.TXT"
    path.write_text("\n".join(lines), encoding="utf-8", errors="surrogatepass")
    try:
        rpc = read_rpc(path)
    except FotogeoError as e:
        _check_message(e)
        return
    assert math.isfinite(rpc.line_off) and rpc.line_scale != 0 and np.isfinite(rpc.samp_num).all()


@FUZZ
@given(raw=st.binary(max_size=300))
def test_rpc_reader_bytes(tmp_path_factory, raw):
    from fotogeo.io.rpc import read_rpc
    path = tmp_path_factory.mktemp("rpcb") / "x.xml"
    path.write_bytes(raw)
    try:
        read_rpc(path)
    except FotogeoError as e:
        _check_message(e)


# -- camera YAML -----------------------------------------------------------------------------

YAML_VALUES = st.one_of(NUMBERS, st.sampled_from(["[900, 700]", "[10.8, 8.4]", "[1]", "[a, b]", "[1e999, 2]",
                                                  "[0, 700]", "[[1, 2], 3]", "pinhole", "brown", "[]", "'x'"]), TEXT)
YAML_LINES = st.lists(st.tuples(st.sampled_from(["", "  ", "    ", "\t"]),
                                st.sampled_from(["cam", "type", "im_size", "focal_len", "sensor_size", "cx", "cy",
                                                 "", "other"]),
                                st.sampled_from([": ", ":", " ", ": # c "]), YAML_VALUES), max_size=9)


@FUZZ
@given(lines=YAML_LINES)
def test_camera_yaml_reader(tmp_path_factory, lines):
    from fotogeo.io.camera import read_interior_orientation
    text = "\n".join(f"{indent}{key}{sep}{value}" for indent, key, sep, value in lines)
    path = tmp_path_factory.mktemp("yaml") / "io.yaml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        cams = read_interior_orientation(path)
    except FotogeoError as e:
        _check_message(e)
        return
    for cam in cams.values():
        assert cam.focal_length > 0 and min(cam.image_size) > 0 and np.isfinite(cam.principal_point).all()


def test_camera_yaml_reader_valid_file(tmp_path):
    """The fuzzed reader still reads a well-formed file (the properties above are not vacuous)."""
    from fotogeo.io.camera import read_interior_orientation
    path = tmp_path / "io.yaml"
    path.write_text("cam:\n  type: pinhole\n  im_size: [900, 700]\n  focal_len: 12.0\n  sensor_size: [10.8, 8.4]\n"
                    "  cx: 0.01\n")
    cam = read_interior_orientation(path)["cam"]
    assert cam.image_size == (900, 700) and cam.principal_point == pytest.approx((459.0, 350.0))
