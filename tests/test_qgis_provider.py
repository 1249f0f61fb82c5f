"""The fotogeo Processing provider in real, headless QGIS: every algorithm through ``processing.run``."""
from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import (  # noqa: E402
    QgsApplication,
    QgsCoordinateReferenceSystem,
    QgsFeature,
    QgsGeometry,
    QgsPointXY,
    QgsProcessingContext,
    QgsProcessingException,
    QgsProcessingFeedback,
    QgsProcessingOutputLayerDefinition,
    QgsProject,
    QgsRasterLayer,
    QgsVectorLayer,
)

ALG_IDS = {"pcafusion", "matchfeatures", "register", "orient", "comparemodels", "transferpoints", "measuretargets", "pointstolayer",
           "layertopoints", "rpcbias", "demo", "registerbatch", "triangulate", "coreg", "interior", "ortho",
           "mosaic", "dsm"}
FRAME = "ngi/frames/3324c_2015_1004_05_0182_RGB.tif"
ORTHO = "ngi/ortho/ngi_rgb_byte_1.tif"


def is_reference_crs(crs) -> bool:
    """The NGI orthophoto's CRS (tmerc lon_0=25, not UTM): register's default output CRS since issue 11."""
    proj = crs.toProj() if hasattr(crs, "toProj") else QgsCoordinateReferenceSystem(crs).toProj()
    return "+proj=tmerc" in proj and "+lon_0=25" in proj
LANDSAT = "landsat_rgb/RGB.byte.tif"
# fewer keypoints than the default keep the robust fit fast; the full pipeline still runs
FAST = {"MAX_KEYPOINTS": 1500}


class Recorder(QgsProcessingFeedback):
    """Records progress values and texts; cancels once progress reaches ``cancel_at`` (percent)."""

    def __init__(self, cancel_at: float | None = None):
        super().__init__()
        self.cancel_at, self.values, self.texts, self.errors = cancel_at, [], [], []
        self.progressChanged.connect(self._progress)

    def _progress(self, value):
        self.values.append(value)
        if self.cancel_at is not None and value >= self.cancel_at:
            self.cancel()

    def setProgressText(self, text):
        self.texts.append(text)
        super().setProgressText(text)

    def reportError(self, error, fatalError=False):
        self.errors.append(error)
        super().reportError(error, fatalError)


def run(alg, params, feedback=None, context=None):
    import processing
    return processing.run(f"fotogeo:{alg}", params, feedback=feedback or Recorder(), context=context)


def sha(path) -> str:
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def files(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# -- the provider ------------------------------------------------------------------------------

def test_provider_registered_with_all_algorithms(qgis_app):
    reg = QgsApplication.processingRegistry()
    prov = reg.providerById("fotogeo")
    assert prov is not None and prov.name() == "fotogeo"
    assert prov.svgIconPath().endswith("icon.svg") and not prov.icon().isNull()
    ids = {a.name() for a in prov.algorithms()}
    assert ids == ALG_IDS
    for i in ids:
        alg = reg.algorithmById(f"fotogeo:{i}")
        assert alg is not None and alg.displayName() and alg.groupId() and alg.group()
        assert len(alg.shortHelpString()) > 200, i
    help_text = reg.algorithmById("fotogeo:register").shortHelpString()
    assert "Dihkan" in help_text and "Bay" in help_text and "2008" in help_text
    assert "Not runnable yet" not in help_text  # every dependency is present in this environment


def _expected_default(option):
    """What the QGIS parameter's default must be for ``option`` (see the fotogeo.options package)."""
    if option.kind == "choice":
        return 0 if option.nullable else option.qgis_choices.index(option.default)
    if option.kind == "choices":
        return None if option.nullable else [option.qgis_choices.index(c) for c in option.default]
    if option.kind == "ints":
        return ",".join(map(str, option.default))
    if option.kind in ("int", "float") and option.nullable:
        return option.automatic
    return None if option.kind == "crs" else option.default  # an empty CRS means the option's default


def _expected_optional(option) -> bool:
    if option.kind in ("crs", "file", "folder", "path", "raster", "raster_out"):
        return True
    if option.kind in ("str", "choices"):
        return option.nullable
    return option.kind in ("int", "float") and option.nullable and option.automatic is None


def test_parameters_are_generated_from_the_option_tables(qgis_app):
    """Every option of an algorithm's tables is a parameter with the table's name, label, default, range,
    enum entries, optional and advanced flags; and the values users rely on are what they were."""
    from qgis.core import QgsProcessingParameterDefinition as Definition

    from processing_provider.algorithms import ALGORITHMS
    reg = QgsApplication.processingRegistry()
    for cls in ALGORITHMS:
        alg = reg.algorithmById(f"fotogeo:{cls.ALG_ID}")
        for option in (o for table in cls.OPTIONS for o in table.values()):
            where = f"{cls.ALG_ID}: {option.name}"
            p = alg.parameterDefinition(option.qgis_name)
            assert p is not None, f"{where}: no parameter {option.qgis_name}"
            assert p.description() == option.label and p.defaultValue() == _expected_default(option), where
            assert bool(p.flags() & Definition.FlagAdvanced) == option.advanced, where
            assert bool(p.flags() & Definition.FlagOptional) == _expected_optional(option), where
            if option.kind in ("choice", "choices"):
                assert p.options() == list(option.qgis_choices) and p.allowMultiple() == (option.kind == "choices")
            if option.kind in ("int", "float"):
                assert p.dataType() == (p.Integer if option.kind == "int" else p.Double), where
                for bound, value in (("minimum", option.minimum), ("maximum", option.maximum)):
                    if value is not None:
                        assert getattr(p, bound)() == value, where
    # the values of today's dialogs, and the one drift fixed: the ratio minimum of register and matchfeatures
    d = {p.name(): p for p in reg.algorithmById("fotogeo:register").parameterDefinitions()}
    assert [d[n].defaultValue() for n in ("RATIO", "RANSAC_THRESHOLD", "CHECK_FRACTION", "MAX_KEYPOINTS", "SEED",
                                          "MAX_MATCH_PIXELS", "RESOLUTION", "HESSIAN_THRESHOLD", "MODEL")] == \
        [0.8, 3.0, 0.3, 8000, 0, 16_000_000, 0.0, 0.0, 0]
    assert d["MODEL"].options()[0] == "default" and d["CHECK_FRACTION"].maximum() == 0.89
    m = {p.name(): p for p in reg.algorithmById("fotogeo:matchfeatures").parameterDefinitions()}
    assert m["RATIO"].minimum() == d["RATIO"].minimum() == 0.05


def test_parameters_read_back_as_the_tools_arguments(qgis_app):
    """Enums, "0 = automatic", empty optional numbers, CRS and field names come back as the tool takes them."""
    from fotogeo.options import REGISTER
    alg = QgsApplication.processingRegistry().algorithmById("fotogeo:register").create()
    context = QgsProcessingContext()
    params = {"MODEL": REGISTER["model"].qgis_choices.index("dlt"), "RESOLUTION": 0, "HESSIAN_THRESHOLD": 400,
              "TARGET_NODATA": 0, "CRS": "EPSG:3857", "CONTRAST": 2, "MUTUAL": False}
    args = alg.option_arguments({**{p.name(): p.defaultValue() for p in alg.parameterDefinitions()}, **params},
                                context)
    assert {k: args[k] for k in ("model", "resolution", "hessian_threshold", "target_nodata", "reference_nodata",
                                 "dst_crs", "contrast", "mutual", "detector", "dem", "camera")} == \
        {"model": "dlt", "resolution": None, "hessian_threshold": 400.0, "target_nodata": 0.0,
         "reference_nodata": None, "dst_crs": "EPSG:3857", "contrast": "linear", "mutual": False, "detector": "surf",
         "dem": None, "camera": None}
    assert alg.option_arguments({"MODEL": 0, "CRS": None}, context)["model"] is None
    assert alg.option_arguments({"MODEL": 0, "CRS": None}, context)["dst_crs"] == "auto"
    transfer = QgsApplication.processingRegistry().algorithmById("fotogeo:transferpoints").create()
    args = transfer.option_arguments({"COL_FIELD": "c", "ROW_FIELD": ""}, context)
    assert args["approx_fields"] == ("c", "row") and args["ref_fields"] == ("ref_col", "ref_row")


# -- pcafusion ---------------------------------------------------------------------------------

def test_pcafusion_same_as_the_tool(qgis_app, data_dir, tmp_path):
    import rasterio

    from fotogeo.tools.register.fuse import fuse_raster
    src = data_dir / LANDSAT
    fb = Recorder()
    out = tmp_path / "pc1.tif"
    res = run("pcafusion", {"INPUT": str(src), "OUTPUT": str(out)}, fb)
    assert res["OUTPUT"] == str(out) and 0.5 < res["EXPLAINED"] <= 1.0
    lyr = QgsRasterLayer(str(out), "pc1")
    assert lyr.isValid() and lyr.bandCount() == 1
    ref = QgsRasterLayer(str(src), "src")
    assert lyr.crs() == ref.crs() and lyr.crs().authid() == "EPSG:32618"
    assert lyr.extent() == ref.extent()
    assert fb.values and max(fb.values) == pytest.approx(100.0) and "writing the first component" in fb.texts
    # the provider is a thin wrapper: the CLI's tool gives the same pixels
    direct = tmp_path / "direct.tif"
    info = fuse_raster(src, direct)
    assert info["explained"] == pytest.approx(res["EXPLAINED"])
    with rasterio.open(out) as a, rasterio.open(direct) as b:
        np.testing.assert_array_equal(a.read(), b.read())


def test_pcafusion_float_and_cancel(qgis_app, data_dir, tmp_path):
    out = tmp_path / "f.tif"
    run("pcafusion", {"INPUT": str(data_dir / LANDSAT), "STRETCH": False, "OUTPUT": str(out)})
    lyr = QgsRasterLayer(str(out), "f")
    assert lyr.isValid() and lyr.dataProvider().dataType(1) == 6  # Qgis.Float32
    cancel_dir = tmp_path / "cancel"
    cancel_dir.mkdir()
    fb = Recorder(cancel_at=15)
    with pytest.raises(QgsProcessingException, match="cancelled"):
        run("pcafusion", {"INPUT": str(data_dir / LANDSAT), "OUTPUT": str(cancel_dir / "c.tif")}, fb)
    assert fb.isCanceled() and max(fb.values) < 100
    assert files(cancel_dir) == []


# -- register ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def registered(qgis_app, data_dir, tmp_path_factory):
    """One register run (SURF, the default) loading its outputs into the project, as the GUI does."""
    import processing
    folder = tmp_path_factory.mktemp("register")
    out = folder / "frame_0182.tif"
    project = QgsProject.instance()
    project.removeAllMapLayers()
    fb = Recorder()
    context = QgsProcessingContext()
    context.setProject(project)
    params = {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME), **FAST,
              "OUTPUT": QgsProcessingOutputLayerDefinition(str(out), project)}
    before = (sha(data_dir / ORTHO), sha(data_dir / FRAME))
    res = processing.runAndLoadResults("fotogeo:register", params, feedback=fb, context=context)
    assert (sha(data_dir / ORTHO), sha(data_dir / FRAME)) == before, "an input was modified"
    return res, folder, fb, project


def test_register_outputs(registered):
    res, folder, fb, _ = registered
    assert files(folder) == ["frame_0182.gpkg", "frame_0182.json", "frame_0182.tif"]
    ras = QgsRasterLayer(res["OUTPUT"], "out")
    assert ras.isValid() and ras.bandCount() == 3
    assert is_reference_crs(ras.crs()) and is_reference_crs(res["OUTPUT_CRS"])
    tie = QgsVectorLayer(res["TIE_POINTS"], "tie", "ogr")
    err = QgsVectorLayer(res["ERROR_VECTORS"], "err", "ogr")
    assert tie.isValid() and err.isValid()
    assert is_reference_crs(tie.crs()) and is_reference_crs(err.crs())
    assert tie.featureCount() == err.featureCount() == res["INLIERS"] >= 50
    roles = [f["role"] for f in tie.getFeatures()]
    assert set(roles) == {"control", "check"}
    assert err.geometryType() == 1  # QgsWkbTypes.LineGeometry
    assert {"dx", "dy", "length"} <= set(err.fields().names())
    report = json.loads(open(res["REPORT"]).read())
    assert report["options"]["detector"] == "surf" and report["options"]["max_keypoints"] == 1500
    assert report["inliers"] == res["INLIERS"]
    assert report["check"]["n"] == roles.count("check")
    assert res["CHECK_RMSE_M"] == pytest.approx(report["check"]["rmse_m"])
    # relief makes one homography metre-level wrong here (5 m ortho pixels): sane, not perfect
    assert 0 < res["CHECK_RMSE_M"] < 100
    # the raster lands on the orthophoto: the output footprint overlaps the reference's (reprojected)
    ref = QgsRasterLayer(report["reference"], "ref")
    from qgis.core import QgsCoordinateTransform
    ext = QgsCoordinateTransform(ref.crs(), ras.crs(), QgsProject.instance()).transformBoundingBox(ref.extent())
    inter = ext.intersect(ras.extent())
    assert inter.area() > 0.5 * ras.extent().area()
    assert fb.values and max(fb.values) == pytest.approx(100.0)
    assert any("resampling" in t for t in fb.texts)


def test_register_layers_loaded_and_styled(registered):
    _, _, _, project = registered
    layers = {lyr.name(): lyr for lyr in project.mapLayers().values()}
    assert {"frame_0182 tie points", "frame_0182 error vectors"} <= set(layers)  # named after the output
    tie, err = layers["frame_0182 tie points"], layers["frame_0182 error vectors"]
    # the vectors are above the raster in the layer tree (Processing alone would put the .tif on top)
    order = [node.layer() for node in project.layerTreeRoot().findLayers()]
    raster_at = next(i for i, lyr in enumerate(order) if isinstance(lyr, QgsRasterLayer))
    assert order.index(tie) < raster_at and order.index(err) < raster_at
    r = tie.renderer()
    assert r.type() == "categorizedSymbol" and r.classAttribute() == "role"
    cats = {c.value(): c.symbol().color().name() for c in r.categories()}
    assert cats["control"] == "#1f78b4" and cats["check"] == "#e31a1c"
    er = err.renderer()
    assert er.type() == "categorizedSymbol" and er.classAttribute() == "role"
    assert all(c.symbol().symbolLayer(0).layerType() == "ArrowLine" for c in er.categories())
    grid = layers["frame_0182 mean error per cell"]  # the gridded mean residual, one arrow per cell, above the raster
    assert grid.featureCount() > 0 and order.index(grid) < raster_at
    assert grid.renderer().symbol().symbolLayer(0).layerType() == "ArrowLine"
    rasters = [lyr for lyr in project.mapLayers().values() if isinstance(lyr, QgsRasterLayer)]
    assert len(rasters) == 1 and is_reference_crs(rasters[0].crs())


def test_register_sift_crs_and_cancel(qgis_app, data_dir, tmp_path):
    """SIFT, an explicit CRS (EPSG:32635, the wrong zone on purpose) and a cancel during resampling."""
    fb = Recorder(cancel_at=70)
    params = {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME), **FAST, "DETECTOR": 1,
              "CRS": QgsCoordinateReferenceSystem("EPSG:32635"), "OUTPUT": str(tmp_path / "x.tif")}
    with pytest.raises(QgsProcessingException, match="cancelled by the user during: resampling"):
        run("register", params, fb)
    assert fb.isCanceled() and 70 <= max(fb.values) < 100
    assert files(tmp_path) == [], "a cancelled run left files behind"
    # the same, not cancelled, with the advanced options set
    res = run("register", {**params, "CONTRAST": 2, "TARGET_NODATA": 0, "MODEL": 2, "RESAMPLING": 1})
    report = json.loads(open(res["REPORT"]).read())
    o = report["options"]
    assert (o["detector"], o["contrast"], o["target_nodata"], o["reference_nodata"], o["model"], o["resampling"]) \
        == ("sift", "linear", 0, None, "affine", "bilinear")
    assert QgsRasterLayer(res["OUTPUT"], "o").crs().authid() == "EPSG:32635"
    assert QgsVectorLayer(res["TIE_POINTS"], "t", "ogr").crs().authid() == "EPSG:32635"


def test_register_terrain_aware_with_dem(registered, data_dir, tmp_path):
    """With the DEM a 3-D model (DLT) orthorectifies the frame: far smaller check error than one homography."""
    from fotogeo.options import REGISTER
    MODELS = REGISTER["model"].qgis_choices
    planar, *_ = registered
    res = run("register", {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME), **FAST,
                           "DEM": str(data_dir / "ngi" / "dem.tif"), "MODEL": MODELS.index("dlt"),
                           "OUTPUT": str(tmp_path / "ortho.tif")})
    with pytest.raises(QgsProcessingException, match="terrain model: it needs a DEM"):
        run("register", {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME), **FAST,
                         "MODEL": MODELS.index("rfm"), "OUTPUT": str(tmp_path / "x.tif")})
    assert files(tmp_path) == ["ortho.gpkg", "ortho.json", "ortho.tif"]
    report = json.loads(open(res["REPORT"]).read())
    assert report["terrain"]["chosen"] == "dlt" and report["terrain"]["dem"].endswith("dem.tif")
    assert res["CHECK_RMSE_M"] < 0.5 * planar["CHECK_RMSE_M"]
    assert is_reference_crs(QgsRasterLayer(res["OUTPUT"], "o").crs())
    assert QgsVectorLayer(res["TIE_POINTS"], "t", "ogr").featureCount() == res["INLIERS"]


def test_register_invalid_parameters(qgis_app, data_dir, tmp_path):
    target = data_dir / FRAME
    base = {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(target), **FAST}
    # out of range for QGIS itself
    with pytest.raises(QgsProcessingException, match="CHECK_FRACTION"):
        run("register", {**base, "CHECK_FRACTION": 0.95, "OUTPUT": str(tmp_path / "a.tif")})
    with pytest.raises(QgsProcessingException, match="REFERENCE"):
        run("register", {**base, "REFERENCE": str(tmp_path / "missing.tif"), "OUTPUT": str(tmp_path / "a.tif")})
    # fotogeo's own checks come through with their message
    digest = sha(target)
    with pytest.raises(QgsProcessingException, match="is also an input; choose another output path"):
        run("register", {**base, "OUTPUT": str(target)})
    assert sha(target) == digest
    with pytest.raises(QgsProcessingException, match="OUTPUT: fotogeo writes GeoTIFF"):
        run("register", {**base, "OUTPUT": str(tmp_path / "b.img")})
    with pytest.raises(QgsProcessingException, match="VECTORS must be a GeoPackage"):
        run("register", {**base, "OUTPUT": str(tmp_path / "b.tif"), "VECTORS": str(tmp_path / "v.shp")})
    # an unreferenced raster as the reference
    import rasterio
    plain = tmp_path / "plain.tif"
    with rasterio.open(data_dir / LANDSAT) as ds:
        arr = ds.read()
    with rasterio.open(plain, "w", driver="GTiff", width=arr.shape[2], height=arr.shape[1], count=3,
                       dtype=arr.dtype) as dst:
        dst.write(arr)
    with pytest.raises(QgsProcessingException, match="has no georeference"):
        run("register", {**base, "REFERENCE": str(plain), "OUTPUT": str(tmp_path / "c.tif")})
    # images that do not overlap: a clear matching error, no output
    with pytest.raises(QgsProcessingException, match=r"only \d+ descriptor matches|inlier"):
        run("register", {**base, "TARGET": str(data_dir / LANDSAT), "OUTPUT": str(tmp_path / "d.tif")})
    assert files(tmp_path) == ["plain.tif"]


def test_missing_runtime_gives_clear_message(qgis_app, data_dir, tmp_path, monkeypatch):
    """Without fotogeo's runtime: algorithms cannot execute, and say what is missing and the one fix."""
    from processing_provider import runner
    monkeypatch.delenv("FOTOGEO_PYTHON")
    monkeypatch.setenv("FOTOGEO_RUNTIME", str(tmp_path / "no-runtime"))
    runner.forget_status()
    try:
        alg = QgsApplication.processingRegistry().algorithmById("fotogeo:pcafusion")
        ok, message = alg.canExecute()
        assert not ok and "no-runtime" in message and "Install / repair runtime" in message
        assert "runtime.py install" in message and "Not runnable yet" in alg.shortHelpString()
        out = tmp_path / "out"
        out.mkdir()
        with pytest.raises(QgsProcessingException, match="is not installed. Fix: menu fotogeo"):
            run("pcafusion", {"INPUT": str(data_dir / LANDSAT), "OUTPUT": str(out / "x.tif")})
        assert files(out) == []
    finally:
        monkeypatch.undo()
        runner.forget_status()
    assert QgsApplication.processingRegistry().algorithmById("fotogeo:pcafusion").canExecute() == (True, "")


# -- Georeferencer points ---------------------------------------------------------------------

POINTS = """#CRS: EPSG:32735
mapX,mapY,sourceX,sourceY,enable,dX,dY,residual
301234.5,6290011.25,0.5,-0.5,1,0.3,-0.4,0.5
301300,6289900.125,640,-1152,0,0,0,0
301250.75,6289950,320.25,-576.125,1,-1.5,2,2.5
"""


def test_points_to_layer_and_back(qgis_app, tmp_path):
    from fotogeo.io.points import read_points
    src = tmp_path / "in.points"
    src.write_text(POINTS)
    res = run("pointstolayer", {"INPUT": str(src), "OUTPUT": str(tmp_path / "gcps.gpkg")})
    assert res["COUNT"] == 3
    lyr = QgsVectorLayer(res["OUTPUT"], "gcps", "ogr")
    assert lyr.isValid() and lyr.featureCount() == 3 and lyr.crs().authid() == "EPSG:32735"
    assert {"id", "col", "row", "z", "role"} <= set(lyr.fields().names())
    feats = sorted(lyr.getFeatures(), key=lambda f: f["id"])
    assert [(f["col"], f["row"], f["role"]) for f in feats] == \
        [(0.5, 0.5, "control"), (640, 1152, "check"), (320.25, 576.125, "control")]
    assert feats[0].geometry().asPoint() == QgsPointXY(301234.5, 6290011.25)
    # and back through the other algorithm: the same points
    back = tmp_path / "back.points"
    res2 = run("layertopoints", {"INPUT": res["OUTPUT"], "OUTPUT": str(back)})
    assert res2["COUNT"] == 3
    a, b = read_points(src), read_points(back)
    np.testing.assert_array_equal(a.map_xy, b.map_xy)
    np.testing.assert_array_equal(a.source_xy, b.source_xy)
    np.testing.assert_array_equal(a.enabled, b.enabled)
    # the CRS parameter overrides the file's
    res3 = run("pointstolayer", {"INPUT": str(src), "CRS": "EPSG:4326", "OUTPUT": str(tmp_path / "g2.gpkg")})
    assert QgsVectorLayer(res3["OUTPUT"], "g2", "ogr").crs().authid() == "EPSG:4326"


def test_points_layer_loaded_and_styled_after_another_run(registered, tmp_path):
    """Each run gets its own post-processor: styling still works after an earlier context is gone."""
    import processing
    src = tmp_path / "in.points"
    src.write_text(POINTS)
    project = QgsProject.instance()
    context = QgsProcessingContext()
    context.setProject(project)
    out = tmp_path / "styled.gpkg"
    processing.runAndLoadResults("fotogeo:pointstolayer",
                                 {"INPUT": str(src), "OUTPUT": QgsProcessingOutputLayerDefinition(str(out), project)},
                                 feedback=Recorder(), context=context)
    loaded = [lyr for lyr in project.mapLayers().values() if lyr.source().startswith(str(out))]
    assert len(loaded) == 1 and loaded[0].featureCount() == 3 and loaded[0].crs().authid() == "EPSG:32735"
    r = loaded[0].renderer()
    assert r.type() == "categorizedSymbol" and r.classAttribute() == "role"


def test_layer_to_points_from_memory_layer_and_errors(qgis_app, tmp_path):
    from fotogeo.io.points import read_points
    mem = QgsVectorLayer("Point?crs=EPSG:32735&field=id:integer&field=col:double&field=row:double"
                         "&field=role:string", "mem", "memory")
    feats = []
    for i, (x, y, c, r, role) in enumerate([(10, 20, 1.5, 2.5, "control"), (30, 40, 3.5, 4.5, "check")], 1):
        f = QgsFeature(mem.fields())
        f.setAttributes([i, c, r, role])
        f.setGeometry(QgsGeometry.fromPointXY(QgsPointXY(x, y)))
        feats.append(f)
    mem.dataProvider().addFeatures(feats)
    out = tmp_path / "mem.points"
    res = run("layertopoints", {"INPUT": mem, "OUTPUT": str(out)})
    assert res["COUNT"] == 2
    gp = read_points(out)
    np.testing.assert_array_equal(gp.source_xy, [[1.5, -2.5], [3.5, -4.5]])
    np.testing.assert_array_equal(gp.enabled, [True, False])
    assert "32735" in gp.crs
    # a layer without col/row: the message names the missing fields
    bad = QgsVectorLayer("Point?crs=EPSG:4326&field=name:string", "bad", "memory")
    f = QgsFeature(bad.fields())
    f.setAttributes(["a"])
    f.setGeometry(QgsGeometry.fromPointXY(QgsPointXY(1, 2)))
    bad.dataProvider().addFeatures([f])
    with pytest.raises(QgsProcessingException, match="lacks the field.*col, row"):
        run("layertopoints", {"INPUT": bad, "OUTPUT": str(tmp_path / "bad.points")})
    # a malformed points file
    broken = tmp_path / "broken.points"
    broken.write_text("mapX,mapY,sourceX,sourceY\n1,2,3\n")
    with pytest.raises(QgsProcessingException, match="line 2"):
        run("pointstolayer", {"INPUT": str(broken), "OUTPUT": str(tmp_path / "broken.gpkg")})
    assert files(tmp_path) == ["broken.points", "mem.points"]


def test_register_tie_points_to_georeferencer(registered, tmp_path):
    """A register tie_points layer goes straight to a .points file the Georeferencer can use."""
    from fotogeo.io.points import read_points
    res, *_ = registered
    out = tmp_path / "tie.points"
    r = run("layertopoints", {"INPUT": res["TIE_POINTS"], "OUTPUT": str(out)})
    tie = QgsVectorLayer(res["TIE_POINTS"], "tie", "ogr")
    assert r["COUNT"] == tie.featureCount()
    gp = read_points(out)
    n_control = sum(1 for f in tie.getFeatures() if f["role"] == "control")
    assert gp.enabled.sum() == n_control
    assert (gp.source_xy[:, 1] <= 0).all() and (gp.source_xy[:, 0] >= 0).all()  # unreferenced convention


def test_demo_loads_styled_results(qgis_app, tmp_path):
    """The demo generates its scene, registers it, compares with the truth and loads four layers."""
    import processing
    project = QgsProject.instance()
    project.removeAllMapLayers()
    context = QgsProcessingContext()
    context.setProject(project)
    res = processing.runAndLoadResults("fotogeo:demo", {"OUTPUT": str(tmp_path / "demo")}, feedback=Recorder(),
                                       context=context)
    assert {"reference.tif", "registered.gpkg", "registered.json", "registered.tif", "target.tif"} <= \
        set(files(tmp_path / "demo"))
    # a good registration of the generated frame: near the best any homography can do against the truth
    assert res["TRUTH_RMSE_M"] < 1.3 * res["BEST_HOMOGRAPHY_RMSE_M"]  # (the bound qgis_process's demo run had)
    layers = {lyr.name(): lyr for lyr in project.mapLayers().values()}
    assert {"Demo reference", "Demo registered", "Demo tie points", "Demo error vectors"} <= set(layers)
    assert layers["Demo registered"].crs().authid() == "EPSG:32635"
    assert layers["Demo tie points"].renderer().type() == "categorizedSymbol"
    if res["ORTHORECTIFIED"]:  # fotogeo.tools.demo.tool also runs the terrain-aware registration with the scene's DEM
        assert res["TERRAIN_TRUTH_RMSE_M"] < min(res["TRUTH_RMSE_M"], 2.0)
        assert layers["Demo orthorectified"].crs().authid() == "EPSG:32635"
    # the rendered aerial block, triangulated: check points near the noise level, its layers loaded
    assert 0 < res["BLOCK_CHECK_RMSE_PLAN_M"] < 1.2 and 0 < res["BLOCK_CHECK_RMSE_Z_M"] < 2.5  # GSD 1.67 m
    assert layers["Demo block footprints"].featureCount() == 8 and layers["Demo block footprints"].geometryType() == 2
    assert layers["Demo block tie points"].featureCount() > 300


def _run_task(alg_id, params, cancel_at=None, timeout=90.0):
    """Run an algorithm as the toolbox dialog does: a QgsProcessingAlgRunnerTask on QGIS's task manager
    (a worker thread), with the dialog's Cancel (task.cancel()) once progress reaches ``cancel_at``."""
    import time

    from qgis.core import QgsProcessingAlgRunnerTask
    from qgis.PyQt.QtCore import QCoreApplication
    alg = QgsApplication.processingRegistry().createAlgorithmById(alg_id)
    context = QgsProcessingContext()
    context.setProject(QgsProject.instance())
    feedback = Recorder()
    task = QgsProcessingAlgRunnerTask(alg, params, context, feedback)
    done = {}
    task.executed.connect(lambda ok, results: done.update(ok=ok, results=results))
    if cancel_at is not None:
        task.progressChanged.connect(lambda p: task.cancel() if p >= cancel_at else None)
    QgsApplication.taskManager().addTask(task)
    t0 = time.monotonic()
    while "ok" not in done and time.monotonic() - t0 < timeout:
        QCoreApplication.processEvents()
        time.sleep(0.01)
    assert "ok" in done, "the task did not finish"
    return done, feedback


def test_register_in_a_background_task_and_cancel_it(qgis_app, data_dir, tmp_path):
    base = {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME), **FAST}
    done, fb = _run_task("fotogeo:register", {**base, "OUTPUT": str(tmp_path / "bg.tif")})
    assert done["ok"] and is_reference_crs(done["results"]["OUTPUT_CRS"]) and fb.values[-1] == pytest.approx(100)
    assert files(tmp_path) == ["bg.gpkg", "bg.json", "bg.tif"]
    cancelled = tmp_path / "cancelled"
    cancelled.mkdir()
    done, fb = _run_task("fotogeo:register", {**base, "OUTPUT": str(cancelled / "c.tif")}, cancel_at=65)
    assert not done["ok"] and fb.isCanceled()
    assert any("cancelled by the user" in e for e in fb.errors), fb.errors
    assert files(cancelled) == []


@pytest.mark.parametrize("alg_id, module, func, skip, rename", [
    ("pcafusion", "tools.register.fuse", "fuse_raster", {"source", "output", "sample_pixels", "block_rows"},
     {"source": "INPUT"}),
    ("orient", "tools.orient.tool", "orient", {"image", "gcps", "fields"}, {}),
    ("comparemodels", "tools.orient.compare", "compare_models", {"image", "gcps", "fields"}, {}),
    ("transferpoints", "tools.points.transfer", "transfer_gcps", {"reference", "search", "points", "output"},
     {"ref_fields": "REF_COL_FIELD", "approx_fields": "COL_FIELD"}),
    ("measuretargets", "tools.points.targets", "measure_targets", {"image", "points", "output"},
     {"approx_fields": "COL_FIELD"}),
    ("register", "tools.register.tool", "register", {"reference", "target", "output", "options", "tie_points"}, {}),
    ("triangulate", "tools.triangulate", "triangulate", set(), {}),
    ("interior", "tools.interior.tool", "interior", {"scans", "camera_report", "output"}, {}),
    ("ortho", "tools.ortho.tool", "ortho", set(), {"dst_crs": "CRS"}),
    ("mosaic", "tools.ortho.mosaic", "mosaic", set(), {}),
])
def test_every_tool_option_has_a_parameter(qgis_app, alg_id, module, func, skip, rename):
    """The tools grow options: each keyword of the tool is a parameter of its algorithm (or knowingly not)."""
    import importlib
    import inspect
    tool = getattr(importlib.import_module(f"fotogeo.{module}"), func)
    names = {p.name() for p in QgsApplication.processingRegistry().algorithmById(f"fotogeo:{alg_id}")
             .parameterDefinitions()}
    keywords = [k for k, p in inspect.signature(tool).parameters.items()
                if p.kind == p.KEYWORD_ONLY and k not in skip | {"overwrite", "progress"}]
    missing = sorted(k for k in keywords if rename.get(k, k.upper()) not in names)
    assert not missing, f"fotogeo.{module}.{func} options without a parameter in fotogeo:{alg_id}: {missing}"


def test_ortho_box_scene(qgis_app, tmp_path):
    """fotogeo:ortho on the rendered box scene with occlusion masking: one orthophoto per image in the folder,
    hidden ground nodata (the same run as the command line's)."""
    import box_scene as bs
    import rasterio
    paths = bs.write_scene(tmp_path)
    out = tmp_path / "out"
    res = run("ortho", {"IMAGES": [str(paths["frame"])], "DEM": str(paths["dsm"]), "CAMERA": str(paths["camera"]),
                        "EO": str(paths["eo"]), "OCCLUSION": True, "RESOLUTION": 0.5, "VIEW_BANDS": True,
                        "OUTDIR": str(out)})
    assert res["ORTHOPHOTOS"] == 1
    with rasterio.open(out / "frame_ortho_view.tif") as ds:
        assert ds.count == 2 and ds.units == ("deg", "m")
    with pytest.raises(QgsProcessingException, match="carries no covariance"):  # eo.txt has no triangulate report
        run("ortho", {"IMAGES": [str(paths["frame"])], "DEM": str(paths["dsm"]), "CAMERA": str(paths["camera"]),
                      "EO": str(paths["eo"]), "UNCERTAINTY": True, "OUTDIR": str(tmp_path / "u")})
    with rasterio.open(out / "frame_ortho.tif") as ds:
        v, t = ds.read(1), ds.transform
    rows, cols = np.mgrid[0:v.shape[0], 0:v.shape[1]]
    X, Y = t * (cols + 0.5, rows + 0.5)
    XY = np.column_stack([X.ravel(), Y.ravel()])
    hidden = bs.hidden_from_camera(XY, -1.0) & ~bs.on_a_box(XY, 1.0)
    assert hidden.sum() > 500 and (v.ravel()[hidden] == 0).mean() > 0.99


def test_ortho_compression_enum(qgis_app, tmp_path):
    """fotogeo:ortho's "Compression" enum reaches the tool: zstd is what the file says."""
    import box_scene as bs
    import rasterio
    from fotogeo.options import ORTHO
    paths = bs.write_scene(tmp_path)
    run("ortho", {"IMAGES": [str(paths["frame"])], "DEM": str(paths["dsm"]), "CAMERA": str(paths["camera"]),
                  "EO": str(paths["eo"]), "RESOLUTION": 0.5, "COMPRESS": ORTHO["compress"].choices.index("zstd"),
                  "OUTDIR": str(tmp_path / "out")})
    with rasterio.open(tmp_path / "out" / "frame_ortho.tif") as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE")["COMPRESSION"] == "ZSTD"


def test_mosaic_two_orthos(qgis_app, tmp_path):
    """fotogeo:mosaic: the mosaic and its seamlines layer (the synthetic pair of tests/test_mosaic.py)."""
    import test_mosaic as tm
    a = tm._ortho(tmp_path / "a.tif", 0, 300, 150, box_value=240)
    b = tm._ortho(tmp_path / "b.tif", 180, 480, 330, tm.GAIN, tm.OFFSET, box_value=30)
    res = run("mosaic", {"ORTHOS": [str(a), str(b)], "OUTPUT": str(tmp_path / "m.tif")})
    assert res["SEAMLINES"] == str(tmp_path / "m.gpkg")
    layer = QgsVectorLayer(res["SEAMLINES_LAYER"], "s", "ogr")
    assert layer.isValid() and layer.featureCount() == 1


def test_dsm_ngi_frames(qgis_app, data_dir, tmp_path):
    """fotogeo:dsm on the NGI frames with their orientation: a DSM where the 24 m DEM is; REPORT left empty writes
    no report (as the CLI without --report), so a file named as the DSM's report would be is left as it was."""
    import rasterio
    ngi = data_dir / "ngi"
    frames = [str(ngi / "frames" / f"3324c_2015_1004_05_{n}_RGB.tif") for n in ("0182", "0184")]
    (tmp_path / "dsm.json").write_text('{"my": "notes"}')
    res = run("dsm", {"IMAGES": frames, "CAMERA": str(ngi / "interior_orientation.yaml"),
                      "EO": str(ngi / "exterior_orientation.txt"), "DEM": str(ngi / "dem.tif"),
                      "OUTPUT": str(tmp_path / "dsm.tif")})
    assert not res["REPORT"] and res["COMPLETENESS"] > 0.8
    assert (tmp_path / "dsm.json").read_text() == '{"my": "notes"}'
    with rasterio.open(tmp_path / "dsm.tif") as ds:
        assert ds.count == 3 and ds.descriptions[:2] == ("height", "pairs")


def test_matchfeatures_layer(qgis_app, data_dir, tmp_path):
    """Detect and match only: a tie-point layer at the reference map positions, with inlier flags."""
    out = tmp_path / "tp.gpkg"
    res = run("matchfeatures", {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME),
                                        "MAX_KEYPOINTS": 3000, "OUTPUT": str(out)})
    layer = QgsVectorLayer(f"{out}|layername=tie_points", "tp", "ogr")
    assert layer.isValid() and layer.featureCount() == res["MATCHES"] > 100
    assert 0 < res["INLIERS"] <= res["MATCHES"]
    assert layer.crs().isValid() and {"target_col", "ref_col", "inlier"} <= set(layer.fields().names())
    with pytest.raises(QgsProcessingException, match="GeoPackage"):
        run("matchfeatures", {"REFERENCE": str(data_dir / ORTHO), "TARGET": str(data_dir / FRAME),
                                      "OUTPUT": str(tmp_path / "tp.shp")})
