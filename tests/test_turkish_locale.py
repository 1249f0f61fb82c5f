"""GDAL under a Turkish locale: the C library's ``strcasecmp`` tells ``i`` from ``I`` there (LC_CTYPE tr_TR), so a
creation option GDAL compares case-insensitively elsewhere is refused when fotogeo passes it in another case.
Runs a write in a fresh process with ``LANG=tr_TR.UTF-8``, the locale compiled into ``tmp_path`` by ``localedef``
(skipped where glibc's locale sources are absent)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SOURCES = Path("/usr/share/i18n/locales/tr_TR")

WRITE = """
import numpy as np, rasterio
from rasterio.transform import from_origin
from fotogeo.io.raster import geotiff_profile
src = dict(driver="GTiff", width=8, height=8, count=3, dtype="uint8", crs="EPSG:32635",
           transform=from_origin(0, 8, 1, 1), interleave="PIXEL")
with rasterio.open("src.tif", "w", **src) as ds:
    ds.write(np.ones((3, 8, 8), "uint8"))
# the source's profile says interleave="pixel" (rasterio reads options back lower case)
with rasterio.open("src.tif") as s, rasterio.open("out.tif", "w", **geotiff_profile(s.profile)) as ds:
    ds.write(s.read())
with rasterio.open("out.tif") as ds:
    print(ds.profile["interleave"], ds.profile["compress"], ds.read().sum())
"""


def _turkish_env(tmp_path):
    """The environment of a process under tr_TR.UTF-8 (skips where it cannot be built or changes nothing)."""
    if not (shutil.which("localedef") and SOURCES.exists()):
        pytest.skip("no glibc locale sources (localedef, /usr/share/i18n/locales/tr_TR) to build tr_TR.UTF-8")
    built = subprocess.run(["localedef", "-i", "tr_TR", "-f", "UTF-8", str(tmp_path / "tr_TR.UTF-8")],
                           capture_output=True, text=True)
    if built.returncode not in (0, 1) or not (tmp_path / "tr_TR.UTF-8").exists():
        pytest.skip(f"localedef could not build tr_TR.UTF-8: {built.stderr.strip()}")
    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "LOCPATH": str(tmp_path), "LANG": "tr_TR.UTF-8", "LC_ALL": "tr_TR.UTF-8",
           "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]), "GDAL_PAM_ENABLED": "NO"}
    check = subprocess.run([sys.executable, "-c", "import ctypes; print(ctypes.CDLL(None).strcasecmp(b'I', b'i'))"],
                           env=env, capture_output=True, text=True, cwd=tmp_path)
    if check.stdout.strip() == "0":
        pytest.skip("this C library compares i and I equal under tr_TR.UTF-8: nothing to check")
    return env


def test_a_geotiff_is_written_under_a_turkish_locale(tmp_path):
    env = _turkish_env(tmp_path)
    run = subprocess.run([sys.executable, "-c", WRITE], env=env, capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["pixel", "deflate", str(3 * 64)], run.stdout


READ_VRT = """
import hashlib, numpy as np, rasterio
from affine import Affine
from rasterio.transform import from_origin
from fotogeo.io.raster import open_raster
from fotogeo.io.vrt import lattice_vrt
if not __import__("os").path.exists("v.tif"):
    with rasterio.open("v.tif", "w", driver="GTiff", width=64, height=64, count=1, dtype="uint8", crs="EPSG:32635",
                       transform=from_origin(0, 64, 1, 1)) as ds:
        ds.write(np.random.default_rng(0).integers(0, 255, (1, 64, 64)).astype("uint8"))
vrt = lattice_vrt("v.tif", open_raster("v.tif"), Affine(1.7, 0, 0.3, 0, -1.7, 64.3), "v.vrt")
with rasterio.open(vrt) as ds:
    print(hashlib.md5(ds.read().tobytes()).hexdigest())
"""


def test_a_lattice_vrt_resamples_alike_under_a_turkish_locale(tmp_path):
    """The mosaic's VRTs name their resampling to GDAL: "bilinear" was read as nearest under tr_TR, silently."""
    env = _turkish_env(tmp_path)
    c = {**env, "LANG": "C.UTF-8", "LC_ALL": "C.UTF-8"}
    runs = [subprocess.run([sys.executable, "-c", READ_VRT], env=e, capture_output=True, text=True, cwd=tmp_path)
            for e in (c, env)]
    assert all(r.returncode == 0 for r in runs), [r.stderr[-1000:] for r in runs]
    assert runs[0].stdout == runs[1].stdout, "the VRT's bilinear resampling differs under tr_TR.UTF-8"


def test_a_vector_layer_is_written_under_a_turkish_locale_without_gdal_errors(tmp_path):
    """pyogrio's GDAL checks at start-up that its configuration option names are sorted by ``strcasecmp``: under
    tr_TR that check printed 57 "ERROR 1: ... isn't correctly sorted" lines on every run writing a GeoPackage, and
    pyogrio warned "driver GPKG does not support creation option VERSION" (GDAL still wrote GeoPackage 1.2)."""
    env = _turkish_env(tmp_path)
    code = ("import shapely; from fotogeo.io.vector import write_layers; from fotogeo.io.tables import read_table; "
            "write_layers('p.gpkg', {'gcps': {'id': ['i1'], 'geometry': shapely.points([[1.0, 2.0]])}}, 'EPSG:32635'); "
            "print(read_table('p.gpkg', 'p.gpkg', layer='gcps')['id'][0])")
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "ERROR" not in run.stderr and "Warning" not in run.stderr, run.stderr[:500]
    assert run.stdout.split() == ["i1"]


def test_the_command_line_writes_a_geotiff_under_a_turkish_locale_without_gdal_warnings(tmp_path):
    """GDAL 3.10 validates creation options by ``strcasecmp``: under tr_TR it warned "driver GTiff does not support
    creation option COMPRESS" (TILED, PREDICTOR, ...) on every GeoTIFF the command line wrote."""
    env = _turkish_env(tmp_path)
    make = ("import numpy as np, rasterio; from rasterio.transform import from_origin; "
            "ds = rasterio.open('s.tif', 'w', driver='GTiff', width=32, height=32, count=3, dtype='uint8', "
            "crs='EPSG:32635', transform=from_origin(0, 32, 1, 1)); "
            "ds.write(np.random.default_rng(0).integers(0, 255, (3, 32, 32)).astype('uint8')); ds.close()")
    subprocess.run([sys.executable, "-c", make], env=env, check=True, cwd=tmp_path)
    run = subprocess.run([sys.executable, "-m", "fotogeo", "fuse", "s.tif", "-o", "f.tif"], env=env,
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "not support" not in run.stderr, run.stderr[:500]
    assert (tmp_path / "f.tif").exists()
