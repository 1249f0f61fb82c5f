"""fotogeo:orient and fotogeo:comparemodels in real, headless QGIS, on GCPs from a real NGI frame's
true geometry (camera + exterior orientation + DEM, see fotogeo.orientation.simulation.make_gcps)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import (  # noqa: E402
    QgsProcessingContext,
    QgsProcessingException,
    QgsProcessingFeedback,
    QgsProcessingOutputLayerDefinition,
    QgsProject,
    QgsRasterLayer,
    QgsVectorLayer,
)

NAME = "3324c_2015_1004_05_0182"
ORIENT_MODELS = ("affine", "affine-height", "bilinear", "collinearity", "dlt", "poly1", "poly2", "poly3",
                 "poly3d-1", "poly3d-2", "poly3d-3", "projective", "rfm", "rfm-common", "rfm-common-i2g",
                 "rfm-common-plain", "rfm-i2g", "rfm-plain", "rfm-plain-i2g", "rfm-poly", "rfm-poly-i2g",
                 "rfm-poly-plain", "similarity")
ORIENT_CHOICES = ("auto",) + ORIENT_MODELS  # orient's MODEL: auto first, its default


def run(alg, params, feedback=None, context=None):
    import processing
    return processing.run(f"fotogeo:{alg}", params, feedback=feedback or QgsProcessingFeedback(), context=context)


def files(folder):
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture(scope="module")
def gcps(qgis_app, data_dir, tmp_path_factory):
    """40 control (0.3 px noise) + 20 exact check points of frame 0182, without heights (the DEM gives them)."""
    import geopandas as gpd
    import shapely

    from fotogeo.io.camera import load_ngi_frame
    from fotogeo.io.raster import read_dem
    from fotogeo.orientation.simulation import make_gcps
    ngi = data_dir / "ngi"
    frame, dem = load_ngi_frame(ngi, NAME), read_dem(ngi / "dem.tif")
    s = make_gcps(frame, dem, 40, 20, "homogeneous", noise=0.3, seed=3)
    ground = np.vstack([s.gcp_ground, s.check_ground])
    pixel = np.vstack([s.gcp_pixel, s.check_pixel])
    path = tmp_path_factory.mktemp("gcps") / "gcps.gpkg"
    gpd.GeoDataFrame({"id": [f"P{i}" for i in range(60)], "c": pixel[:, 0], "r": pixel[:, 1],
                      "role": ["control"] * 40 + ["check"] * 20},
                     geometry=shapely.points(ground[:, :2]), crs=dem.crs.to_wkt()).to_file(path, driver="GPKG")
    return {"path": str(path), "image": str(ngi / "frames" / f"{NAME}_RGB.tif"), "dem": str(ngi / "dem.tif"),
            "camera": str(ngi / "interior_orientation.yaml")}


def same_map_crs(a, b) -> bool:
    """Same horizontal CRS (the DEM's compound CRS comes back with its geoid named differently)."""
    def horizontal(crs):
        return {t for t in crs.toProj().split() if not t.startswith(("+geoidgrids", "+geoid_crs", "+vunits"))}
    return a.isValid() and b.isValid() and horizontal(a) == horizontal(b)


def base(g, **kw):
    return {"IMAGE": g["image"], "GCPS": g["path"], "DEM": g["dem"], "COL_FIELD": "c", "ROW_FIELD": "r", **kw}


def test_orient_dlt_all_outputs(gcps, tmp_path):
    from fotogeo.io.points import read_points
    model = ORIENT_CHOICES.index("dlt")
    out = {"REPORT": str(tmp_path / "r.json"), "VECTORS": str(tmp_path / "v.gpkg"), "PLOT": str(tmp_path / "p.png"),
           "POINTS": str(tmp_path / "g.points"), "RECTIFY": str(tmp_path / "rect.tif")}
    res = run("orient", base(gcps, MODEL=model, RESOLUTION=10.0, **out))
    assert files(tmp_path) == ["g.points", "p.png", "r.json", "rect.tif", "v.gpkg"]
    rep = json.loads(open(out["REPORT"]).read())
    assert rep["model_name"] == res["MODEL_NAME"] == "dlt" and rep["n_gcps"] == 60
    assert rep["check"]["n"] == 20 and res["CHECK_RMS_XY_PX"] == pytest.approx(rep["check"]["rms_xy_px"])
    assert res["CHECK_RMS_XY_PX"] < 0.6  # 0.3 px noise on the control points; DLT models the frame
    dem_crs = QgsRasterLayer(gcps["dem"], "dem").crs()
    gl = QgsVectorLayer(res["GCP_LAYER"], "g", "ogr")
    ev = QgsVectorLayer(res["ERROR_VECTORS"], "e", "ogr")
    assert gl.isValid() and ev.isValid() and gl.featureCount() == ev.featureCount() == 60
    assert same_map_crs(gl.crs(), dem_crs) and same_map_crs(ev.crs(), dem_crs)
    assert {"dx", "dy", "length"} <= set(ev.fields().names())
    rect = QgsRasterLayer(res["RECTIFY"], "rect")
    assert rect.isValid() and same_map_crs(rect.crs(), dem_crs) and rect.rasterUnitsPerPixelX() == pytest.approx(10.0)
    gp = read_points(out["POINTS"])
    assert len(gp) == 60 and gp.enabled.sum() == rep["control"]["n"]
    assert open(out["PLOT"], "rb").read(8) == b"\x89PNG\r\n\x1a\n"


def test_orient_from_points_file_and_rpc_export(gcps, tmp_path):
    """The Georeferencer path: GCPs as a .points file (heights from the DEM), an RFM exported as GDAL RPC."""
    import rasterio

    from fotogeo.io.points import read_points
    pts = tmp_path / "g.points"
    gtif = tmp_path / "gcp.tif"
    run("orient", base(gcps, MODEL=ORIENT_CHOICES.index("poly1"), POINTS=str(pts), GCP_TIFF=str(gtif)))
    with rasterio.open(gtif) as ds:  # the control points as GDAL GCPs, for gdalwarp -order 1 / QGIS
        gcp_list, gcp_crs = ds.gcps
        assert len(gcp_list) == read_points(pts).enabled.sum() and gcp_crs is not None
    rpc = tmp_path / "rpc.tif"
    res = run("orient", {"IMAGE": gcps["image"], "GCPS": str(pts), "DEM": gcps["dem"],
                         "MODEL": ORIENT_CHOICES.index("rfm"), "RPC": str(rpc), "VECTORS": None, "REPORT": None,
                         "SNOOPING": False})  # snooping refits the RFM once per GCP: slow, not tested here
    assert res["MODEL_NAME"] == "rfm" and res["RPC"] == str(rpc) and res["GCP_LAYER"] is None
    with rasterio.open(rpc) as ds:
        assert ds.rpcs is not None and ds.rpcs.height_scale > 0
    assert QgsRasterLayer(str(rpc), "rpc").isValid()
    assert files(tmp_path) == ["g.points", "gcp.tif", "rpc.tif"]


def test_orient_errors_and_cancel(gcps, tmp_path):
    with pytest.raises(QgsProcessingException, match="needs the interior orientation"):
        run("orient", base(gcps, MODEL=ORIENT_CHOICES.index("collinearity"), REPORT=str(tmp_path / "a.json")))
    with pytest.raises(QgsProcessingException, match="is not one"):
        run("orient", base(gcps, MODEL=ORIENT_CHOICES.index("poly1"), RPC=str(tmp_path / "x.tif")))
    with pytest.raises(QgsProcessingException, match=r"lacks the field\(s\) col"):
        run("orient", {"IMAGE": gcps["image"], "GCPS": gcps["path"], "REPORT": str(tmp_path / "b.json")})
    assert files(tmp_path) == []

    class CancelAt(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.progressChanged.connect(lambda v: self.cancel() if v >= 60 else None)

    fb = CancelAt()
    with pytest.raises(QgsProcessingException, match="cancelled"):
        run("orient", base(gcps, MODEL=ORIENT_CHOICES.index("dlt"), RECTIFY=str(tmp_path / "r.tif"),
                           RESOLUTION=5.0, REPORT=str(tmp_path / "r.json"), VECTORS=str(tmp_path / "v.gpkg")), fb)
    assert fb.isCanceled() and files(tmp_path) == []


def test_orient_collinearity_layers_loaded_and_styled(gcps, tmp_path):
    project = QgsProject.instance()
    context = QgsProcessingContext()
    context.setProject(project)
    import processing
    vec = tmp_path / "coll.gpkg"
    res = processing.runAndLoadResults(
        "fotogeo:orient", base(gcps, MODEL=ORIENT_CHOICES.index("collinearity"), CAMERA=gcps["camera"],
                               VECTORS=QgsProcessingOutputLayerDefinition(str(vec), project)),
        feedback=QgsProcessingFeedback(), context=context)
    assert res["CHECK_RMS_XY_PX"] < 0.6
    loaded = {lyr.source(): lyr for lyr in project.mapLayers().values() if lyr.source().startswith(str(vec))}
    assert len(loaded) == 2
    renderers = {src.split("layername=")[-1] if "layername" in src else "first": lyr.renderer()
                 for src, lyr in loaded.items()}
    assert renderers["error_vectors"].categories()[0].symbol().symbolLayer(0).layerType() == "ArrowLine"
    gl = renderers.get("first") or renderers.get("gcps")
    assert gl.type() == "categorizedSymbol" and gl.classAttribute() == "class"  # role, or blunder / suspect


def test_compare_models(gcps, tmp_path):
    import csv
    table = tmp_path / "t.csv"
    md = tmp_path / "t.md"
    fb = QgsProcessingFeedback()
    res = run("comparemodels", base(gcps, MODELS=[ORIENT_MODELS.index("affine"), ORIENT_MODELS.index("dlt")],
                                    COUNTS="20,10", TRIALS=2, TABLE=str(table), MARKDOWN=str(md)), fb)
    rows = list(csv.DictReader(open(table)))
    assert res["ROWS"] == len(rows) == 2 * 2 * 2
    assert {(r["model"], r["spread"], r["n_control"]) for r in rows} == \
        {(m, s, c) for m in ("affine", "dlt") for s in ("homogeneous", "heterogeneous") for c in ("20", "10")}
    dlt20 = [r for r in rows if r["model"] == "dlt" and r["n_control"] == "20" and r["spread"] == "homogeneous"][0]
    affine20 = [r for r in rows if r["model"] == "affine" and r["n_control"] == "20"
                and r["spread"] == "homogeneous"][0]
    assert float(dlt20["check_rms_xy_px"]) < float(affine20["check_rms_xy_px"])  # relief: 3-D beats 2-D
    assert md.read_text().startswith("### homogeneous (px)")
    with pytest.raises(QgsProcessingException, match="'twenty': 'twenty' is not N or N/M"):
        run("comparemodels", base(gcps, COUNTS="twenty", TABLE=str(tmp_path / "x.csv")))
    assert files(tmp_path) == ["t.csv", "t.md"]


def test_orient_from_a_project_layer(gcps, tmp_path):
    """GCPs digitised in the project (a memory layer) work like the file they came from."""
    from qgis.core import QgsFeatureRequest
    layer = QgsVectorLayer(gcps["path"], "gcps", "ogr").materialize(QgsFeatureRequest())
    assert layer.providerType() == "memory" and layer.featureCount() == 60
    params = {"IMAGE": gcps["image"], "DEM": gcps["dem"], "COL_FIELD": "c", "ROW_FIELD": "r",
              "MODEL": ORIENT_CHOICES.index("dlt")}
    from_layer = run("orient", {**params, "GCP_LAYER_INPUT": layer, "REPORT": str(tmp_path / "a.json")})
    from_file = run("orient", {**params, "GCPS": gcps["path"], "REPORT": str(tmp_path / "b.json")})
    assert from_layer["CHECK_RMS_XY_PX"] == pytest.approx(from_file["CHECK_RMS_XY_PX"], rel=1e-9)
    with pytest.raises(QgsProcessingException, match="not both and not neither"):
        run("orient", {**params, "GCPS": gcps["path"], "GCP_LAYER_INPUT": layer})
    with pytest.raises(QgsProcessingException, match="not both and not neither"):
        run("orient", params)


def test_orient_skips_a_gcp_outside_the_image_and_says_where_the_heights_came_from(gcps, tmp_path):
    """The CLI's policy in QGIS (one mechanism, fotogeo.io.gcps.inside_image): the GCP typed outside the image is
    named with its pixel in the log and the report's 'skipped', the rest fitted; the DEM's heights are stated."""
    import geopandas as gpd
    table = gpd.read_file(gcps["path"])
    table.loc[3, "c"] = 5000.0
    table.to_file(tmp_path / "typo.gpkg")
    warnings = []

    class Log(QgsProcessingFeedback):
        def pushWarning(self, warning):
            warnings.append(warning)
            super().pushWarning(warning)

    res = run("orient", base(gcps, GCPS=str(tmp_path / "typo.gpkg"), MODEL=ORIENT_CHOICES.index("dlt"),
                             REPORT=str(tmp_path / "r.json")), feedback=Log())
    rep = json.loads((tmp_path / "r.json").read_text())
    assert [s["id"] for s in rep["skipped"]] == ["P3"] and rep["n_gcps"] == 59 and res["CHECK_RMS_XY_PX"] < 0.6
    assert any("P3 (col 5000.0, row" in w and "skipped" in w for w in warnings), warnings
    assert any("heights of 60 of 60 GCPs" in w and "dem.tif" in w for w in warnings), warnings
    assert rep["heights"]["dem"] == 60
