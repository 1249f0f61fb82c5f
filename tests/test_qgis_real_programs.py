"""fotogeo in the real QGIS programs: ``qgis_process`` and the desktop ``qgis`` under Xvfb.

The other QGIS tests import QGIS into the venv's Python, which loads the pip wheels' GDAL/GEOS
before QGIS's and so cannot see what a user meets. Here a fresh profile
(``QGIS_CUSTOM_CONFIG_PATH``) is set up by the install command (``scripts/qgis_install.py``, what
``make qgis-install`` runs) and Debian's own binaries run the algorithms: QGIS loads its GDAL 3.6,
the plugin runs fotogeo in its runtime. The runtime is kept in ``build/qgis-test-runtime``
between runs (the first run downloads the wheels, ~40 s). Inputs are copied to tmp; qgis_process
runs with GDAL's PAM on, as a user's does, and every run through :func:`qgis_process` fails when it
leaves a file beside one of its inputs (``<input>.aux.xml`` …) or modifies one.

``FOTOGEO_UPDATE_SCREENSHOTS=1`` copies the desktop screenshots to ``docs/`` (shown in the README).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fotogeo.options import COMPARE, ORIENT

ROOT = Path(__file__).resolve().parents[1]
RUNTIME = ROOT / "build" / "qgis-test-runtime"
QGIS_PROCESS = "/usr/bin/qgis_process.bin"  # the /usr/bin/qgis_process wrapper adds --noversioncheck, refused by 3.22
QGIS_DESKTOP = "/usr/bin/qgis.bin"
FRAME = "ngi/frames/3324c_2015_1004_05_0182_RGB.tif"
ORTHO = "ngi/ortho/ngi_rgb_byte_1.tif"
LANDSAT = "landsat_rgb/RGB.byte.tif"

pytestmark = [pytest.mark.qgis, pytest.mark.skipif(not os.path.exists(QGIS_PROCESS),
                                                   reason="Debian's qgis package is not installed (make test installs it)")]


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    """A fresh QGIS settings tree whose default profile got fotogeo from the install command."""
    config = tmp_path_factory.mktemp("qgis-config")
    profile = config / "profiles" / "default"
    r = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / "qgis_install.py"), "--profile", str(profile),
                        "--runtime", str(RUNTIME)], capture_output=True, text=True, timeout=600, env=_env(config))
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    ini = (profile / "QGIS" / "QGIS3.ini").read_text()
    assert "fotogeo_qgis=true" in ini and f"runtime={RUNTIME}" in ini
    assert (profile / "python" / "plugins" / "fotogeo_qgis" / "fotogeo" / "worker.py").is_file()
    return config


def _env(config, pam: str = "YES") -> dict:
    """qgis_process's environment: the fresh profile, GDAL's PAM as a user has it (on) unless ``pam``."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("FOTOGEO_") and k != "PYTHONPATH"}
    env.update(QGIS_CUSTOM_CONFIG_PATH=str(config), GDAL_PAM_ENABLED=pam, QT_QPA_PLATFORM="offscreen")
    return env


def input_files(params) -> dict:
    """The existing files among parameter values (a layer URI's path before ``|``) → (size, mtime)."""
    out = {}
    for vs in params.values():
        for v in (vs if isinstance(vs, list) else [vs]):
            path = Path(str(v).split("|")[0])
            if path.is_file():
                out[path] = (path.stat().st_size, path.stat().st_mtime_ns)
    return out


def beside_inputs(before: dict) -> list:
    """What a run left beside or did to the inputs ``before`` (see :func:`input_files`): side files named
    after an input (``<input>.aux.xml``, ``.ovr``, ``-wal`` …) that were not there, inputs changed."""
    problems = [f"{p} was modified" for p, stamp in before.items()
                if not p.is_file() or (p.stat().st_size, p.stat().st_mtime_ns) != stamp]
    for p in before:
        problems += [f"{q} appeared beside the input {p.name}" for q in p.parent.iterdir()
                     if q.name.startswith(p.name) and q != p and q not in before]
    return problems


def qgis_process(config, alg, **params) -> dict:
    """Run ``fotogeo:<alg>`` in qgis_process (a list value repeats the parameter: a multiple-layer input);
    fails when it leaves anything beside its inputs."""
    args = [QGIS_PROCESS, "--json", "run", f"fotogeo:{alg}", "--"] + [
        f"{k}={v}" for k, vs in params.items() for v in (vs if isinstance(vs, list) else [vs])]
    before = input_files(params)
    r = subprocess.run(args, capture_output=True, text=True, timeout=180, env=_env(config))
    assert r.returncode == 0, f"{alg}: exit {r.returncode}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    assert not beside_inputs(before), f"{alg}: {beside_inputs(before)}"
    return json.loads(r.stdout[r.stdout.index("{"):])["results"]


@pytest.fixture(scope="module")
def inputs(data_dir, tmp_path_factory):
    folder = tmp_path_factory.mktemp("inputs")
    for rel in (FRAME, ORTHO, LANDSAT, "ngi/dem.tif"):
        shutil.copy(data_dir / rel, folder / Path(rel).name)
    return folder


def test_qgis_process_lists_and_runs_the_algorithms(config, inputs, tmp_path):
    r = subprocess.run([QGIS_PROCESS, "list"], capture_output=True, text=True, timeout=120, env=_env(config))
    assert r.returncode == 0 and "fotogeo:register" in r.stdout and "fotogeo:comparemodels" in r.stdout
    # pcafusion and register (outputs left empty go beside the raster)
    res = qgis_process(config, "pcafusion", INPUT=inputs / "RGB.byte.tif", OUTPUT=tmp_path / "pc1.tif")
    assert 0.5 < res["EXPLAINED"] <= 1 and (tmp_path / "pc1.tif").is_file()
    out = tmp_path / "reg" / "frame_0182.tif"
    out.parent.mkdir()
    res = qgis_process(config, "register", REFERENCE=inputs / Path(ORTHO).name, TARGET=inputs / Path(FRAME).name,
                       MAX_KEYPOINTS=1500, OUTPUT=out)
    assert sorted(p.name for p in out.parent.iterdir()) == ["frame_0182.gpkg", "frame_0182.json", "frame_0182.tif"]
    report = json.loads(out.with_suffix(".json").read_text())
    assert res["INLIERS"] == report["inliers"] >= 50 and res["CHECK_RMSE_M"] == pytest.approx(report["check"]["rmse_m"])
    # the runtime's libraries, not QGIS's GDAL 3.6: the wheels ran where they work
    assert not report["versions"]["gdal"].startswith("3.6")
    # tie points → Georeferencer .points → GCP layer → orientation and comparison on them
    points = tmp_path / "tie.points"
    res = qgis_process(config, "layertopoints", INPUT=f"{out.with_suffix('.gpkg')}|layername=tie_points",
                       OUTPUT=points)
    assert res["COUNT"] == report["inliers"]
    res = qgis_process(config, "pointstolayer", INPUT=points, OUTPUT=tmp_path / "gcps.gpkg")
    assert res["COUNT"] == report["inliers"]
    res = qgis_process(config, "orient", IMAGE=inputs / Path(FRAME).name, GCPS=tmp_path / "gcps.gpkg",
                       DEM=inputs / "dem.tif", MODEL=ORIENT["model"].qgis_choices.index("dlt"), REPORT=tmp_path / "orient.json",
                       VECTORS=tmp_path / "orient.gpkg")
    assert res["MODEL_NAME"] == "dlt" and 0 < res["CONTROL_RMS_XY_PX"] < 50
    res = qgis_process(config, "comparemodels", IMAGE=inputs / Path(FRAME).name, GCPS=tmp_path / "gcps.gpkg",
                       DEM=inputs / "dem.tif", MODELS=",".join(str(COMPARE["models"].qgis_choices.index(m)) for m in ("affine", "dlt")), COUNTS="20", TRIALS=1, TABLE=tmp_path / "cmp.csv")
    assert res["ROWS"] >= 2 and (tmp_path / "cmp.csv").read_text().startswith("model,")
    res = qgis_process(config, "matchfeatures", REFERENCE=inputs / Path(ORTHO).name,
                       TARGET=inputs / Path(FRAME).name, MAX_KEYPOINTS=1500, OUTPUT=tmp_path / "tp.gpkg")
    assert 0 < res["INLIERS"] <= res["MATCHES"]
    assert sorted(p.name for p in inputs.iterdir() if p.suffix == ".xml") == []  # no .aux.xml beside the inputs


def test_qgis_process_runs_the_matching_rpc_batch_and_coreg_algorithms(config, inputs, data_dir, tmp_path):
    """The algorithms the first test does not reach: transferpoints, measuretargets, rpcbias, registerbatch, coreg
    and register with local co-registration. (demo is not run here: it runs through the provider in
    tests/test_qgis_provider.py, whose demo test asserts the bounds this run had and the layers it loads;
    tests/test_demo.py the tool's numbers.)"""
    import numpy as np
    import pandas as pd
    import rasterio

    from synthetic_images import x_target_scene
    from test_rpc_bias_tool import _gcp_layer
    # transferpoints: an orthophoto crop and the same crop shifted by (3.4, -2.3) px (exact Fourier shift)
    shift = np.array([3.4, -2.3])
    with rasterio.open(inputs / Path(ORTHO).name) as ds:
        ref = ds.read(2, window=((300, 556), (200, 456))).astype(np.float64)
    fy, fx = np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij")
    search = np.real(np.fft.ifft2(np.fft.fft2(ref) * np.exp(-2j * np.pi * (fx * shift[0] + fy * shift[1]))))
    for name, img in (("ref.tif", ref), ("search.tif", search)):
        with rasterio.open(tmp_path / name, "w", driver="GTiff", width=256, height=256, count=1,
                           dtype="float32") as ds:
            ds.write(img.astype(np.float32)[None])
    pts = np.random.default_rng(1).uniform(60, 196, (25, 2))
    pd.DataFrame({"id": range(25), "ref_col": pts[:, 0], "ref_row": pts[:, 1], "col": np.round(pts[:, 0]),
                  "row": np.round(pts[:, 1])}).to_csv(tmp_path / "pts.csv", index=False)
    res = qgis_process(config, "transferpoints", REFERENCE=tmp_path / "ref.tif", SEARCH=tmp_path / "search.tif",
                       POINTS=tmp_path / "pts.csv", OUTPUT=tmp_path / "moved.csv")
    out = pd.read_csv(tmp_path / "moved.csv")
    ok = (out.status == "converged").to_numpy()
    assert res["CONVERGED"] == ok.sum() >= 18
    assert np.sqrt(np.mean(np.sum((out.loc[ok, ["col", "row"]].to_numpy() - (pts[ok] + shift)) ** 2, axis=1))) < 0.1
    # measuretargets: X targets at known sub-pixel centres
    centres = np.array([[60.3, 50.7], [150.55, 120.25], [240.8, 90.4]])
    img = x_target_scene(centres).astype(np.float32)
    with rasterio.open(tmp_path / "t.tif", "w", driver="GTiff", width=img.shape[1], height=img.shape[0], count=1,
                       dtype="float32") as ds:
        ds.write(img[None])
    pd.DataFrame({"col": np.round(centres[:, 0]) + 1, "row": np.round(centres[:, 1]) - 1}).to_csv(
        tmp_path / "approx.csv", index=False)
    res = qgis_process(config, "measuretargets", IMAGE=tmp_path / "t.tif", POINTS=tmp_path / "approx.csv",
                       POLARITY=1, OUTPUT=tmp_path / "m.csv")
    assert res["MEASURED"] == 3
    assert np.abs(pd.read_csv(tmp_path / "m.csv")[["col", "row"]].to_numpy() - centres).max() < 0.05
    # rpcbias: the QuickBird-2 vendor RPC corrected with its GCPs (3 of 5 inside the image)
    shutil.copy(data_dir / "qb2" / "qb2_basic1b.tif", tmp_path / "qb2.tif")
    _gcp_layer(data_dir / "qb2", tmp_path / "qb2_gcps.gpkg")
    res = qgis_process(config, "rpcbias", IMAGE=tmp_path / "qb2.tif", GCPS=tmp_path / "qb2_gcps.gpkg",
                       OUTPUT=tmp_path / "qb2_rpc.tif")
    assert res["RMS_BEFORE_PX"] > 3.0 and res["RMS_AFTER_PX"] < 0.15
    with rasterio.open(tmp_path / "qb2_rpc.tif") as ds:
        assert float(ds.tags(ns="RPC")["SAMP_OFF"]) != pytest.approx(float(
            rasterio.open(tmp_path / "qb2.tif").tags(ns="RPC")["SAMP_OFF"]))
    # registerbatch: two scenes under known warps (one task each on a local Dask cluster in the runtime)
    from batch_scenes import make_scene
    scenes = [make_scene(inputs / "RGB.byte.tif", tmp_path, k)[0] for k in (1, 2)]
    res = qgis_process(config, "registerbatch", REFERENCE=inputs / "RGB.byte.tif", TARGETS=scenes,
                       OUTDIR=tmp_path / "batch", MAX_KEYPOINTS=1500)
    assert res["OK"] == 2 and res["FAILED"] == 0
    # coreg, and register with local co-registration: a seasonal pair feature matching cannot register
    import coreg_scenes as cs
    ref_a, tgt_a, _ = cs.seasonal_landsat()
    ref = cs.write_geotiff(tmp_path / "season_ref.tif", ref_a, dtype="uint8")
    tgt = cs.write_geotiff(tmp_path / "season_tgt.tif", tgt_a, dtype="uint8")
    res = qgis_process(config, "coreg", REFERENCE=ref, TARGET=tgt, OUTPUT=tmp_path / "season.tif", GRID_SPACING=32)
    assert res["RELIABLE"] >= 200 and res["RMS_AFTER_PX"] < 0.1
    assert (tmp_path / "season.gpkg").is_file() and (tmp_path / "season_field.tif").is_file()
    res = qgis_process(config, "register", REFERENCE=ref, TARGET=tgt, OUTPUT=tmp_path / "season_reg.tif", LOCAL="true")
    assert (tmp_path / "season_reg_field.tif").is_file() and res["INLIERS"] >= 50


def test_qgis_process_ortho_and_mosaic(config, inputs, data_dir, tmp_path):
    """ortho (the two NGI frames with camera, EO and DEM; the QuickBird image with its RPC) and mosaic in
    qgis_process: the runtime reads every orientation input and writes the orthophotos and the seamlines."""
    import rasterio
    ngi = data_dir / "ngi"
    for f in ("interior_orientation.yaml", "exterior_orientation.txt"):
        shutil.copy(ngi / f, tmp_path / f)
    frames = []
    for f in sorted((ngi / "frames").glob("*.tif")):
        shutil.copy(f, tmp_path / f.name)
        frames.append(tmp_path / f.name)
    res = qgis_process(config, "ortho", IMAGES=frames, DEM=inputs / "dem.tif",
                       CAMERA=tmp_path / "interior_orientation.yaml", EO=tmp_path / "exterior_orientation.txt",
                       RESOLUTION=5, OUTDIR=tmp_path / "orthos")
    assert res["ORTHOPHOTOS"] == 2
    orthos = sorted((tmp_path / "orthos").glob("*_ortho.tif"))
    res = qgis_process(config, "mosaic", ORTHOS=orthos, OUTPUT=tmp_path / "m.tif")
    assert (tmp_path / "m.gpkg").is_file() and res["SEAMLINES_LAYER"].endswith("layername=seamlines")
    shutil.copy(data_dir / "qb2" / "qb2_basic1b.tif", tmp_path / "qb2.tif")
    res = qgis_process(config, "ortho", IMAGES=[tmp_path / "qb2.tif"], DEM=inputs / "dem.tif", RPC=True,
                       DEM_HEIGHTS=1, RESOLUTION=6, OUTDIR=tmp_path / "qb2")
    with rasterio.open(tmp_path / "qb2" / "qb2_ortho.tif") as ds:
        assert res["ORTHOPHOTOS"] == 1 and ds.res == (6.0, 6.0) and ds.read_masks(1).mean() > 100


def test_qgis_process_bad_input_is_one_line(config, inputs, tmp_path):
    """A fotogeo error reaches qgis_process as the tool's one-line message, not a Python traceback."""
    r = subprocess.run([QGIS_PROCESS, "run", "fotogeo:register", "--", f"REFERENCE={inputs / 'RGB.byte.tif'}",
                        f"TARGET={inputs / Path(FRAME).name}", f"OUTPUT={inputs / Path(FRAME).name}"],
                       capture_output=True, text=True, timeout=120, env=_env(config))
    assert r.returncode != 0
    text = r.stdout + r.stderr
    assert "is also an input; choose another output path" in text and "Traceback" not in text


def test_qgis_process_help_is_plain_text(config):
    """qgis_process prints an algorithm's help as it is (the desktop dialog renders it as HTML): no tags, no
    entities; and fotogeo:dsm's help names both kinds of images it takes."""
    for alg in ("fotogeo:ortho", "fotogeo:dsm"):
        r = subprocess.run([QGIS_PROCESS, "help", alg], capture_output=True, text=True, timeout=120, env=_env(config))
        assert r.returncode == 0, r.stderr[-2000:]
        assert not re.search(r"</?b>|&lt;|&gt;|&amp;", r.stdout), r.stdout[:3000]
        if alg == "fotogeo:ortho":
            assert "Occlusion masking (with a DSM" in r.stdout and "<name>_ortho_sigma.tif" in r.stdout
        else:
            assert "frame cameras" in r.stdout and "satellite images carrying an RPC" in r.stdout


def test_qgis_process_leaves_nothing_beside_raster_inputs(config, tmp_path):
    """qgis_process loads every raster parameter as a layer before the provider's code runs, and with GDAL's PAM
    on (a user's default) GDAL would save that layer's statistics as ``<input>.aux.xml`` beside the input: the
    provider turns PAM off in a qgis_process that runs a fotogeo algorithm, for a single raster (pcafusion) and a
    multiple-layer input (interior's scans); a QGIS algorithm in the same program keeps QGIS's behaviour."""
    from film_scans import RMK_LIKE, render_scan, report_yaml
    from test_interior import write_scan

    from fotogeo.options.interior import INTERIOR
    from fotogeo.tools.demo.tool import make_scene
    folder = tmp_path / "in"
    make_scene(folder, seed=3, size=200, pixel=20.0)
    write_scan(folder / "scan.tif", render_scan(RMK_LIKE, kind="cross", theta=1.0))
    (folder / "cal.yaml").write_text(report_yaml(RMK_LIKE, kind="cross"))
    names = sorted(p.name for p in folder.iterdir())
    (tmp_path / "out").mkdir()
    res = qgis_process(config, "pcafusion", INPUT=folder / "reference.tif", OUTPUT=tmp_path / "out" / "f.tif")
    assert 0.5 < res["EXPLAINED"] <= 1
    res = qgis_process(config, "interior", SCANS=[folder / "scan.tif"], CAMERA_REPORT=folder / "cal.yaml",
                       SCAN_PIXEL_UM=150.0, ROTATION=INTERIOR["rotation"].qgis_choices.index("0"),
                       OUTDIR=tmp_path / "interior")
    assert res["SCANS_DONE"] == 1
    assert sorted(p.name for p in folder.iterdir()) == names
    # the control: QGIS's own algorithm on a raster, same program and environment, writes its statistics
    r = subprocess.run([QGIS_PROCESS, "run", "native:rasterlayerstatistics", "--", f"INPUT={folder / 'target.tif'}",
                        "BAND=1"], capture_output=True, text=True, timeout=120, env=_env(config))
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert (folder / "target.tif.aux.xml").is_file()


DESKTOP_SCRIPT = r'''
import os, sys
from qgis.PyQt.QtCore import QTimer
from qgis.PyQt.QtWidgets import QDockWidget, QTextEdit
from qgis.utils import iface
from qgis.core import QgsApplication, QgsProject
OUT, REF, TGT, TESTS = (os.environ[k] for k in ("FOTOGEO_DESKTOP_OUT", "FOTOGEO_DESKTOP_REF", "FOTOGEO_DESKTOP_TGT",
                                                "FOTOGEO_DESKTOP_TESTS"))
sys.path.insert(0, TESTS)
from desktop_harness import Harness
HARNESS = Harness(OUT)
state, finish, guard = HARNESS.state, HARNESS.finish, HARNESS.guard

def grab(widget, name, width=960):
    HARNESS.grab(widget, name, width)

@guard
def toolbox():
    import qgis.utils
    iface.mainWindow().resize(1280, 800)
    state["plugins"] = list(qgis.utils.active_plugins)
    state["can_execute"] = list(QgsApplication.processingRegistry().algorithmById("fotogeo:register").canExecute())
    dock = iface.mainWindow().findChild(QDockWidget, "ProcessingToolbox")
    dock.show()
    dock.raise_()
    dock.searchBox.setText("fotogeo")
    QTimer.singleShot(1500, guard(lambda: (grab(iface.mainWindow(), "qgis_toolbox.png"), dialog())))

@guard
def dialog():
    # as a user works: the frame and the orthophoto are in the project, the orthophoto is the active layer,
    # and the dialog opens with nothing chosen — Target must not start on the Reference layer
    import processing
    iface.addRasterLayer(TGT, "frame 0182")
    iface.setActiveLayer(iface.addRasterLayer(REF, "orthophoto"))
    dlg = processing.createAlgorithmDialog("fotogeo:register", {
        "MAX_KEYPOINTS": 1500, "OUTPUT": os.path.join(OUT, "frame_0182.tif")})
    dlg.resize(900, 700)
    dlg.show()
    globals()["DLG"] = dlg
    chosen = dlg.createProcessingParameters()
    state["dialog_inputs"] = [QgsProject.instance().mapLayer(chosen[k]).name() if QgsProject.instance().mapLayer(
        chosen[k]) else str(chosen[k]) for k in ("REFERENCE", "TARGET")]
    QTimer.singleShot(1000, guard(lambda: (grab(dlg, "qgis_register_dialog.png", 900), dlg.runAlgorithm(), wait(0))))

@guard
def wait(n):
    if len(QgsProject.instance().mapLayers()) >= 6 or n > 200:
        state["layers"] = [node.layer().name() for node in QgsProject.instance().layerTreeRoot().findLayers()]
        state["log"] = DLG.findChild(QTextEdit, "txtLog").toPlainText()
        model = iface.layerTreeView().layerTreeModel()
        state["legend"] = {node.layer().name(): [n.data(0) for n in model.layerLegendNodes(node)]
                           for node in QgsProject.instance().layerTreeRoot().findLayers()}
        state["expanded"] = [node.layer().name() for node in QgsProject.instance().layerTreeRoot().findLayers()
                             if node.isExpanded()]
        DLG.close()
        iface.mapCanvas().zoomToFullExtent()
        QTimer.singleShot(3000, guard(lambda: (grab(iface.mainWindow(), "qgis_results.png"), finish())))
    else:
        QTimer.singleShot(500, guard(lambda: wait(n + 1)))

QTimer.singleShot(3000, toolbox)
'''


@pytest.mark.skipif(not shutil.which("xvfb-run") or not os.path.exists(QGIS_DESKTOP),
                    reason="xvfb and the qgis desktop are not installed (make test installs them)")
def test_desktop_qgis_runs_register_from_its_dialog(config, inputs, tmp_path):
    """The desktop under Xvfb: the plugin loads, register runs from its dialog, its layers load above the raster."""
    script = tmp_path / "startup.py"
    script.write_text(DESKTOP_SCRIPT)
    out = tmp_path / "desktop"
    out.mkdir()
    env = {**_env(config, pam="NO"), "FOTOGEO_DESKTOP_OUT": str(out), "FOTOGEO_DESKTOP_REF": str(inputs / Path(ORTHO).name),
           "FOTOGEO_DESKTOP_TGT": str(inputs / Path(FRAME).name),
           "FOTOGEO_DESKTOP_TESTS": str(Path(__file__).resolve().parent)}
    env.pop("QT_QPA_PLATFORM")
    subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", QGIS_DESKTOP, "--nologo", "--noversioncheck",
                    "--code", str(script)], capture_output=True, text=True, timeout=240, env=env, cwd=tmp_path)
    # QGIS 3.22 may abort while quitting (after the script wrote its result): judge by the result
    state = json.loads((out / "result.json").read_text())
    assert "error" not in state, state.get("error")
    assert "fotogeo_qgis" in state["plugins"] and state["can_execute"] == [True, ""]
    # the dialog opened on the active layer for Reference and on another layer for Target
    assert state["dialog_inputs"] == ["orthophoto", "frame 0182"]
    # the run's layers above the inputs, named after the output file, vectors above the raster
    assert state["layers"] == ["frame_0182 tie points", "frame_0182 error vectors", "frame_0182 mean error per cell",
                               "frame_0182 registered", "orthophoto", "frame 0182"]
    # the exaggeration sentence is a line of the legend itself, the layer expanded so that it shows
    vectors = state["legend"]["frame_0182 error vectors"]
    assert any(re.fullmatch(r"drawn x\d+; 1 mm on the map = [\d.]+ m of error \(at 1:[\d ]+\)", t) for t in vectors), vectors
    assert "frame_0182 error vectors" in state["expanded"]
    # the CLI's summary lines, units named; a 2-D fit over relief points to the DEM by its label, not --dem
    assert re.search(r"check +n= *\d+ +RMSE [\d.]+ m +\([\d.]+ reference px\)", state["log"]), state["log"][-800:]
    assert "“DEM (terrain-aware registration" in state["log"] and "--dem" not in state["log"]
    assert re.search(r"inliers \d+ \(\d+ within RANSAC's 3 reference px", state["log"])
    assert "PROJ string" not in state["log"]
    assert {"frame_0182.tif", "frame_0182.gpkg", "frame_0182.json"} <= {p.name for p in out.iterdir()}
    for png in ("qgis_toolbox.png", "qgis_register_dialog.png", "qgis_results.png"):
        assert (out / png).stat().st_size > 20_000, png
        if os.environ.get("FOTOGEO_UPDATE_SCREENSHOTS"):
            shutil.copy(out / png, ROOT / "docs" / png)
