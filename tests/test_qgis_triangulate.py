"""fotogeo:triangulate in real, headless QGIS: through the provider (processing) and through qgis_process."""
from __future__ import annotations

import json
import os
import warnings

import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingContext, QgsProcessingException, QgsProject  # noqa: E402
from qgis.PyQt.QtCore import Qt  # noqa: E402

from fotogeo.orientation.block_simulation import simulate_block  # noqa: E402
from fotogeo.tools.triangulate import triangulate  # noqa: E402
from test_qgis_provider import Recorder  # noqa: E402
from test_qgis_real_programs import QGIS_PROCESS, config, qgis_process  # noqa: E402,F401 - config: a fixture
from test_triangulate import CAMERA, write_block  # noqa: E402


@pytest.fixture(scope="module")
def block_files(tmp_path_factory):
    """The 2 x 5 synthetic block of test_triangulate written to files, and the tool's own result on them."""
    folder = tmp_path_factory.mktemp("block")
    sb = simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                        n_check=8)
    frames, checks = write_block(folder, sb)
    (folder / "direct").mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = triangulate(frames, folder / "camera.yaml", folder / "eo.txt", folder / "tie.csv", folder / "direct",
                          gcps=folder / "gcp_list.txt", check_points=checks, image_sigma=0.3)
    return folder, frames, checks, rep


def _params(folder, frames, checks, out):
    return {"FRAMES": [str(f) for f in frames], "CAMERA": str(folder / "camera.yaml"), "EO": str(folder / "eo.txt"),
            "OBSERVATIONS": str(folder / "tie.csv"), "GCPS": str(folder / "gcp_list.txt"), "CHECK_POINTS": checks,
            "IMAGE_SIGMA": 0.3, "OUTDIR": str(out)}


def test_triangulate_through_the_provider_loads_styled_layers(qgis_app, block_files, tmp_path):
    """The algorithm gives the tool's numbers (same inputs, same report) and loads the block's layers, the
    control styled by role."""
    import processing
    folder, frames, checks, direct = block_files
    project = QgsProject.instance()
    project.removeAllMapLayers()
    context = QgsProcessingContext()
    context.setProject(project)
    params = {**_params(folder, frames, checks, tmp_path / "out"), "ORTHORECTIFY": True}
    res = processing.runAndLoadResults("fotogeo:triangulate", params, feedback=Recorder(), context=context)
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["statistics"]["check"] == pytest.approx(direct["statistics"]["check"], rel=1e-6)
    assert res["CHECK_RMSE_XY"] == pytest.approx(direct["statistics"]["check"]["rmse_planimetric_m"], rel=1e-6)
    assert res["SIGMA0"] == pytest.approx(direct["sigma0"], rel=1e-6) and res["BLUNDERS"] >= 0
    assert os.path.exists(res["REPORT_HTML"])
    # no self-calibration asked (an unset SELF_CALIBRATION): the camera written is the one given, held fixed
    assert "fixed:" in (tmp_path / "out" / "camera.yaml").read_text()
    layers = {lyr.name(): lyr for lyr in project.mapLayers().values()}
    assert {"Frame footprints", "Tie points", "Control and check points"} <= set(layers)
    control = layers["Control and check points"]
    assert control.renderer().type() == "categorizedSymbol" and control.renderer().classAttribute() == "role"
    assert layers["Frame footprints"].featureCount() == 10
    assert layers["Frame footprints"].crs().authid() == "EPSG:32635"
    orthos = [lyr for name, lyr in layers.items() if name.endswith(" ortho")]
    assert len(orthos) == 10 and all(o.crs().authid() == "EPSG:32635" for o in orthos)
    names = [n.name() for n in project.layerTreeRoot().findLayers()]
    assert names.index("Control and check points") < min(names.index(o.name()) for o in orthos)  # vectors on top
    # footprints: outlines only, below the tie and control points (they hid them, filled and on top)
    assert names.index("Frame footprints") > max(names.index("Tie points"), names.index("Control and check points"))
    fill = layers["Frame footprints"].renderer().symbol().symbolLayer(0)
    assert fill.brushStyle() == Qt.NoBrush and fill.strokeStyle() == Qt.SolidLine


def _control_layer(folder, checks):
    """The block's gcp_list.txt as a QGIS memory point layer, as the GCP picker makes it: fields id, frame,
    col, row (corner convention), z, role (the check points named ``check``), geometry X, Y in EPSG:32635."""
    from qgis.core import QgsFeature, QgsGeometry, QgsPointXY, QgsVectorLayer

    from fotogeo.io.block import read_gcp_list
    gcp = read_gcp_list(folder / "gcp_list.txt")
    layer = QgsVectorLayer("Point?crs=EPSG:32635&field=id:string&field=frame:string&field=col:double"
                           "&field=row:double&field=z:double&field=role:string", "control", "memory")
    features = []
    for name, (x, y, z), (col, row), frame in zip(gcp.name, gcp.ground, gcp.pixel, gcp.frame):
        f = QgsFeature(layer.fields())
        f.setAttributes([str(name), str(frame), float(col), float(row), float(z),
                         "check" if name in checks.split(",") else "control"])
        f.setGeometry(QgsGeometry.fromPointXY(QgsPointXY(float(x), float(y))))
        features.append(f)
    assert layer.dataProvider().addFeatures(features)[0] and layer.featureCount() == len(gcp.name)
    return layer


def _second_layer_of_a_geopackage(layer, path):
    """``layer`` written as the second layer ``control`` of the GeoPackage ``path`` (a decoy first layer
    ``other`` without the GCP fields): the tool, given the file alone, would read the wrong one."""
    from qgis.core import QgsCoordinateTransformContext, QgsVectorFileWriter, QgsVectorLayer
    decoy = QgsVectorLayer("Point?crs=EPSG:32635&field=name:string", "other", "memory")
    for name, source, mode in (("other", decoy, QgsVectorFileWriter.CreateOrOverwriteFile),
                               ("control", layer, QgsVectorFileWriter.CreateOrOverwriteLayer)):
        options = QgsVectorFileWriter.SaveVectorOptions()
        options.driverName, options.layerName, options.actionOnExistingFile = "GPKG", name, mode
        err = QgsVectorFileWriter.writeAsVectorFormatV3(source, str(path), QgsCoordinateTransformContext(), options)
        assert err[0] == QgsVectorFileWriter.NoError, err
    second = QgsVectorLayer(f"{path}|layername=control", "control", "ogr")
    assert second.isValid() and second.featureCount() == layer.featureCount()
    return second


def test_triangulate_control_from_a_project_point_layer(qgis_app, block_files, tmp_path):
    """Ground control as a point layer of the project (a memory layer; a layer of a multi-layer GeoPackage)
    gives the file's adjustment: the worker gets it as a file exported to Processing's temporary folder; the
    check points come from the layer's role field. A file and a layer together are refused."""
    import processing
    from qgis.core import QgsProcessingUtils
    folder, frames, checks, direct = block_files
    memory = _control_layer(folder, checks)
    params = {**_params(folder, frames, checks, tmp_path), "GCPS": None, "CHECK_POINTS": None}
    for i, layer in enumerate((memory, _second_layer_of_a_geopackage(memory, tmp_path / "control.gpkg"))):
        res = processing.run("fotogeo:triangulate", {**params, "GCP_LAYER_INPUT": layer,
                                                     "OUTDIR": str(tmp_path / f"out{i}")}, feedback=Recorder())
        rep = json.loads((tmp_path / f"out{i}" / "report.json").read_text())
        assert rep["statistics"]["check"]["n"] == direct["statistics"]["check"]["n"] > 0
        assert rep["statistics"]["check"] == pytest.approx(direct["statistics"]["check"], rel=1e-6)
        assert res["SIGMA0"] == pytest.approx(direct["sigma0"], rel=1e-6)
        exported = rep["gcps"]  # not the decoy-first file: a GeoPackage of its own in Processing's temporary folder
        assert exported.endswith(".gpkg") and os.path.dirname(exported).startswith(QgsProcessingUtils.tempFolder())
    with pytest.raises(QgsProcessingException, match="either as a file .GCPS. or as a point layer"):
        processing.run("fotogeo:triangulate", {**params, "GCPS": str(folder / "gcp_list.txt"),
                                               "GCP_LAYER_INPUT": memory, "OUTDIR": str(tmp_path / "both")},
                       feedback=Recorder())


def test_an_unset_multiple_choice_is_none(qgis_app):
    """QGIS 3.22 reads an unset optional multiple enum as [0] (the first choice): SELF_CALIBRATION would
    free the focal length, comparemodels' MODELS would fit only the first model."""
    from qgis.core import QgsApplication

    from fotogeo.options import COMPARE, TRIANGULATE
    reg, context = QgsApplication.processingRegistry(), QgsProcessingContext()
    tri, comp = reg.algorithmById("fotogeo:triangulate"), reg.algorithmById("fotogeo:comparemodels")
    assert tri.option_value({}, TRIANGULATE["self_calibration"], context) is None
    assert comp.option_value({"MODELS": None}, COMPARE["models"], context) is None
    assert tri.option_value({"SELF_CALIBRATION": [0, 3]}, TRIANGULATE["self_calibration"], context) == ("f", "k1")


def test_triangulate_bad_input_is_one_message(qgis_app, block_files, tmp_path):
    folder, frames, checks, _ = block_files
    params = _params(folder, frames, checks, tmp_path / "out")
    params["CHECK_POINTS"] = "nosuchpoint"
    with pytest.raises(QgsProcessingException, match="check_points: nosuchpoint are not GCP names"):
        import processing
        processing.run("fotogeo:triangulate", params, feedback=Recorder())
    assert not any((tmp_path / "out").iterdir())


@pytest.mark.skipif(not os.path.exists(QGIS_PROCESS), reason="Debian's qgis package is not installed")
def test_triangulate_through_qgis_process(config, block_files, tmp_path):
    """The real qgis_process program (fotogeo installed into a fresh profile, as in test_qgis_real_programs)
    runs fotogeo:triangulate, a multiple-layer FRAMES given by repeating it, and writes the tool's adjustment."""
    folder, frames, checks, direct = block_files
    res = qgis_process(config, "triangulate", **_params(folder, frames, checks, tmp_path / "out"))
    assert res["CHECK_RMSE_XY"] == pytest.approx(direct["statistics"]["check"]["rmse_planimetric_m"], rel=1e-6)
    assert res["CHECK_RMSE_Z"] == pytest.approx(direct["statistics"]["check"]["rmse_z_m"], rel=1e-6)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(
        ["exterior_orientation.txt", "camera.yaml", "block.gpkg", "report.json", "report.html"])


def test_ortho_uncertainty_of_triangulate_outputs_loads_with_a_legend_in_metres(qgis_app, block_files, tmp_path):
    """fotogeo:ortho with UNCERTAINTY on triangulate's own output folder: the σ raster of each frame loads as a
    pseudocolour layer stretched over its values, its legend labelled in metres."""
    import processing
    folder, frames, _, _ = block_files
    project = QgsProject.instance()
    project.removeAllMapLayers()
    context = QgsProcessingContext()
    context.setProject(project)
    params = {"IMAGES": [str(frames[0])], "CAMERA": str(folder / "camera.yaml"),
              "EO": str(folder / "direct" / "exterior_orientation.txt"), "HEIGHT": 0.0, "DEM_SIGMA": 2.0,
              "CRS": "EPSG:32635", "UNCERTAINTY": True, "OUTDIR": str(tmp_path / "o")}
    processing.runAndLoadResults("fotogeo:ortho", params, feedback=Recorder(), context=context)
    layers = {lyr.name(): lyr for lyr in project.mapLayers().values()}
    sigma = [lyr for name, lyr in layers.items() if name.endswith("σ (m)")]
    assert len(sigma) == 1, sorted(layers)
    renderer = sigma[0].renderer()
    assert renderer.type() == "singlebandpseudocolor"
    ramp = renderer.shader().rasterShaderFunction()
    assert ramp.legendSettings().suffix() == " m"
    lo, hi = ramp.minimumValue(), ramp.maximumValue()
    assert 0 < lo < hi < 50  # the raster's own range, not the style's 0 … 1 placeholder
    assert (lo, hi) != (0.0, 1.0)


@pytest.mark.data
@pytest.mark.skipif(not os.path.exists(QGIS_PROCESS), reason="Debian's qgis package is not installed")
def test_drone_frames_through_qgis_process_need_no_crs(config, data_dir, tmp_path):
    """The real eBee JPEGs through qgis_process with the frames alone (issue 20): no CRS, no camera, no orientation
    given — the UTM zone, the camera and the start come from the files as on the command line — and a block it
    refuses says so in the dialog's words (the option's label, not its command-line flag)."""
    import shutil
    import subprocess

    from fotogeo.options import TRIANGULATE
    from fotogeo.options.shared import UNDETERMINED
    from test_qgis_real_programs import _env
    src = data_dir / "drone_snowpeak" / "img"
    if not src.is_dir():
        pytest.skip(f"real test data not found at {src} (an older ../shared/data without drone_snowpeak)")
    frames = [shutil.copy(src / f"{n}.JPG", tmp_path) for n in ("IMG_2280", "IMG_2281", "IMG_2282", "IMG_2212",
                                                                 "IMG_2213")]
    res = qgis_process(config, "triangulate", FRAMES=frames[:3], OUTDIR=tmp_path / "strip")
    rep = json.loads((tmp_path / "strip" / "report.json").read_text())
    assert rep["crs"] == "EPSG:32654" and rep["start"]["crs_rule"] == "the UTM zone of the images' GPS positions"
    assert res["SIGMA0"] == pytest.approx(rep["sigma0"]) and len(rep["frames"]) == 3
    r = subprocess.run([QGIS_PROCESS, "--json", "run", "fotogeo:triangulate", "--", *[f"FRAMES={f}" for f in frames[3:]],
                        f"OUTDIR={tmp_path / 'turn'}", f"UNDETERMINED={UNDETERMINED.index('fail')}"],
                       capture_output=True, text=True, timeout=180, env=_env(config))
    text = r.stdout + r.stderr
    assert r.returncode != 0 and "does not determine frame(s) IMG_2212" in text, text[-3000:]
    assert f"“{TRIANGULATE['undetermined'].label}” drop" in text and "--undetermined" not in text, text[-3000:]
    assert "Traceback" not in text
    # QGIS makes the folder; the refusal writes only its report (the pairs tried) there
    assert not (tmp_path / "turn").exists() or {p.name for p in (tmp_path / "turn").iterdir()} <= {"report.json"}


@pytest.mark.data
def test_drone_frame_without_gps_is_refused_in_the_dialogs_words(qgis_app, data_dir, tmp_path):
    """A copy of an eBee JPEG without its GPS: the refusal names the frame and every way to start it by the
    parameter labels of the dialog (no command-line flag left), and writes nothing."""
    import processing
    from fotogeo.options import TRIANGULATE
    from jpeg_metadata import copy_frames, rename_ifd0_tag
    src = data_dir / "drone_snowpeak" / "img"
    if not src.is_dir():
        pytest.skip(f"real test data not found at {src} (an older ../shared/data without drone_snowpeak)")
    frames = copy_frames(src, ["IMG_2280", "IMG_2281"], tmp_path / "img")
    rename_ifd0_tag(frames[1], 0x8825, 0xC7FF)  # GPSInfo -> a private tag: no GPS
    with pytest.raises(QgsProcessingException) as err:
        processing.run("fotogeo:triangulate", {"FRAMES": [str(f) for f in frames], "OUTDIR": str(tmp_path / "out")},
                       feedback=Recorder())
    text = str(err.value)
    assert "IMG_2281 carry no GPS position" in text and "--" not in text, text
    for label in (TRIANGULATE["geoinfo"].label, "Approximate exterior orientation", "Ground control",
                  "Reference orthophoto(s)", TRIANGULATE["dem"].label):
        assert f"“{label}”" in text, (label, text)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_triangulate_uncertainty_loads_each_sigma_raster_with_a_legend_in_metres(qgis_app, block_files, tmp_path):
    """fotogeo:triangulate with ORTHORECTIFY and UNCERTAINTY: beside each orthophoto its σ raster, loaded as
    fotogeo:ortho loads it (pseudocolour, legend in metres)."""
    import processing
    folder, frames, checks, _ = block_files
    project = QgsProject.instance()
    project.removeAllMapLayers()
    context = QgsProcessingContext()
    context.setProject(project)
    params = {**_params(folder, frames, checks, tmp_path / "out"), "ORTHORECTIFY": True, "UNCERTAINTY": True,
              "DEM_SIGMA": 2.0}
    processing.runAndLoadResults("fotogeo:triangulate", params, feedback=Recorder(), context=context)
    sigma = [lyr for lyr in project.mapLayers().values() if lyr.name().endswith("σ (m)")]
    assert len(sigma) == 10 and all(lyr.source().endswith("_ortho_sigma.tif") for lyr in sigma)
    assert {lyr.renderer().type() for lyr in sigma} == {"singlebandpseudocolor"}
    assert sigma[0].renderer().shader().rasterShaderFunction().legendSettings().suffix() == " m"


def test_only_the_orthophotos_written_are_loaded(qgis_app, tmp_path):
    """A frame that was not orthorectified (its report entry an error, e.g. off the DEM) has no
    ``<frame>_ortho.tif``: the algorithm loads the orthophotos written and that one not."""
    from processing_provider.algorithms.triangulate import TriangulateAlgorithm
    rep = {"sigma0": 1.0, "statistics": {"check": {}, "image_rms_px": 0.3, "n_blunders": 0},
           "orthorectified": {"a": {"width": 10, "height": 10},
                              "b": {"error": "not orthorectified: the DEM does not cover it"}}}
    context = QgsProcessingContext()
    context.setProject(QgsProject.instance())
    TriangulateAlgorithm()._outputs(rep, str(tmp_path), context)
    loaded = {os.path.basename(uri) for uri in context.layersToLoadOnCompletion()}
    assert "a_ortho.tif" in loaded and "b_ortho.tif" not in loaded
