"""``qgis_process run fotogeo:… --INPUT=img/a.JPG --OUTPUT=out/b.tif`` from a shell: paths relative to the
user's folder are the user's, although fotogeo's worker starts in the plugin's folder (inputs found, outputs
written there and nowhere else); and the console shows no GDAL noise about frames without a georeference.

Small rendered rasters (a JPEG without georeference, two overlapping GeoTIFF tiles), so each run takes seconds.
"""
from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_qgis_real_programs import QGIS_PROCESS, _env, beside_inputs, config, input_files  # noqa: F401 - fixture

pytestmark = [pytest.mark.qgis, pytest.mark.skipif(not os.path.exists(QGIS_PROCESS),
                                                   reason="Debian's qgis package is not installed (make test installs it)")]

#: GDAL's complaint when QGIS loads a raster without a geotransform as a layer (nothing is wrong with the frame)
NO_TRANSFORM = "Unable to compute a transformation"


def _texture(rows: int, cols: int, seed: int) -> np.ndarray:
    """Three correlated bands of smooth texture (uint8, band-first), so a principal component is meaningful."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(rows // 8 + 1, cols // 8 + 1)).repeat(8, 0).repeat(8, 1)[:rows, :cols]
    bands = [base + 0.3 * rng.normal(size=(rows, cols)) for _ in range(3)]
    return np.stack([np.clip(100 + 40 * b, 0, 255) for b in bands]).astype(np.uint8)


def _inputs(folder: Path) -> None:
    """``img/frame 1.JPG`` (no georeference, as a drone frame) and ``tiles/a.tif``, ``tiles/b.tif`` (overlapping)."""
    import cv2
    import rasterio
    from rasterio.transform import from_origin
    (folder / "img").mkdir()
    (folder / "tiles").mkdir()
    image = _texture(240, 320, 1)
    assert cv2.imwrite(str(folder / "img" / "frame 1.JPG"), np.moveaxis(image, 0, -1)[..., ::-1])
    whole = _texture(200, 300, 2)
    for name, col in (("a", 0), ("b", 120)):
        with rasterio.open(folder / "tiles" / f"{name}.tif", "w", driver="GTiff", width=180, height=200, count=3,
                           dtype="uint8", crs="EPSG:32634", transform=from_origin(500000 + col, 4000000, 1, 1)) as d:
            d.write(whole[:, :, col:col + 180])


def _run(config, folder: Path, alg: str, *params: str) -> subprocess.CompletedProcess:  # noqa: F811
    """``qgis_process --json run fotogeo:<alg> -- <params>`` started in ``folder`` (the user's shell)."""
    before = input_files({i: str(folder / p.split("=", 1)[1]) for i, p in enumerate(params)})
    r = subprocess.run([QGIS_PROCESS, "--json", "run", f"fotogeo:{alg}", "--", *params], cwd=folder,
                       capture_output=True, text=True, timeout=180, env=_env(config))
    assert r.returncode == 0, f"{alg}: exit {r.returncode}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    assert "ResourceWarning" not in r.stdout + r.stderr, r.stderr[-3000:]  # the worker's pipes closed (main: 4)
    assert not beside_inputs(before), beside_inputs(before)
    return r


def test_relative_inputs_and_outputs_are_the_callers(config, tmp_path):  # noqa: F811
    user = tmp_path / "user folder"
    user.mkdir()
    _inputs(user)
    (user / "out").mkdir()
    # a single raster (a JPEG without georeference) and a raster destination, both relative
    r = _run(config, user, "pcafusion", "INPUT=img/frame 1.JPG", "OUTPUT=out/pc1.tif")
    results = json.loads(r.stdout[r.stdout.index("{"):])["results"]
    assert 0.5 < results["EXPLAINED"] <= 1 and (user / "out" / "pc1.tif").is_file()
    assert NO_TRANSFORM not in r.stdout + r.stderr  # the JPEG has no georeference, and that is no error
    # several rasters (a multiple-layer input) and an output with a file beside it, relative
    _run(config, user, "mosaic", "ORTHOS=tiles/a.tif", "ORTHOS=tiles/b.tif", "OUTPUT=out/mosaic.tif")
    assert (user / "out" / "mosaic.tif").is_file() and (user / "out" / "mosaic.gpkg").is_file()
    import rasterio
    with rasterio.open(user / "out" / "mosaic.tif") as m:
        assert (m.width, m.height) == (300, 200) and m.transform.c == 500000
    # written where the user said, nowhere else (not in the plugin's folder, not in the user's folder's root)
    assert sorted(p.name for p in user.iterdir()) == ["img", "out", "tiles"]
    assert sorted(p.name for p in (user / "out").iterdir()) == ["mosaic.gpkg", "mosaic.tif", "pc1.tif"]
    plugin = config / "profiles" / "default" / "python" / "plugins" / "fotogeo_qgis"
    assert not list(plugin.glob("out")) and not list(plugin.rglob("*.tif"))



def test_frames_without_georeference_make_no_gdal_noise(config, tmp_path):  # noqa: F811
    """A list of rasters with a JPEG frame in it: checked by qgis_process without loading them as layers, so the
    console shows fotogeo's refusal (a mosaic needs orthophotos) and nothing from GDAL about the frame."""
    _inputs(tmp_path)
    r = subprocess.run([QGIS_PROCESS, "run", "fotogeo:mosaic", "--", "ORTHOS=img/frame 1.JPG", "ORTHOS=tiles/a.tif",
                        "OUTPUT=mosaic.tif"], cwd=tmp_path, capture_output=True, text=True, timeout=180,
                       env=_env(config))
    console = r.stdout + r.stderr
    assert r.returncode != 0 and "frame 1.JPG" in console and not (tmp_path / "mosaic.tif").exists()
    assert NO_TRANSFORM not in console and "ERROR 1" not in console and "Traceback" not in console
