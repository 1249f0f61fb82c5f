"""fotogeo:transferpoints and fotogeo:measuretargets in real, headless QGIS."""
from __future__ import annotations

import numpy as np
import pytest
from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

pytestmark = [pytest.mark.qgis]
need_qgis()

from qgis.core import QgsProcessingException, QgsProcessingFeedback, QgsVectorLayer  # noqa: E402

SHIFT = np.array([3.4, -2.3])


def run(alg, params, feedback=None):
    import processing
    return processing.run(f"fotogeo:{alg}", params, feedback=feedback or QgsProcessingFeedback())


def _write(path, img):
    import rasterio
    img = np.asarray(img)
    with rasterio.open(path, "w", driver="GTiff", width=img.shape[-1], height=img.shape[-2], count=1,
                       dtype=img.dtype) as ds:
        ds.write(img.reshape(1, *img.shape[-2:]))


@pytest.fixture(scope="module")
def shifted(qgis_app, data_dir, tmp_path_factory):
    """A real orthophoto crop and the same crop shifted by (3.4, -2.3) px (exact Fourier shift)."""
    import pandas as pd
    import rasterio
    d = tmp_path_factory.mktemp("shift")
    with rasterio.open(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        ref = ds.read(2, window=((300, 556), (200, 456))).astype(np.float64)
    fy, fx = np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij")
    search = np.real(np.fft.ifft2(np.fft.fft2(ref) * np.exp(-2j * np.pi * (fx * SHIFT[0] + fy * SHIFT[1]))))
    _write(d / "ref.tif", ref.astype(np.float32))
    _write(d / "search.tif", search.astype(np.float32))
    pts = np.random.default_rng(1).uniform(60, 196, (25, 2))
    pd.DataFrame({"gcp": range(25), "rc": pts[:, 0], "rr": pts[:, 1], "col": np.round(pts[:, 0]),
                  "row": np.round(pts[:, 1])}).to_csv(d / "pts.csv", index=False)
    return d, pts


def test_transfer_points_recovers_a_subpixel_shift(shifted, tmp_path):
    import pandas as pd
    d, pts = shifted
    params = {"REFERENCE": str(d / "ref.tif"), "SEARCH": str(d / "search.tif"), "POINTS": str(d / "pts.csv"),
              "REF_COL_FIELD": "rc", "REF_ROW_FIELD": "rr", "ID_FIELD": "gcp"}
    res = run("transferpoints", {**params, "OUTPUT": str(tmp_path / "out.csv")})
    out = pd.read_csv(tmp_path / "out.csv")
    ok = (out.status == "converged").to_numpy()
    assert res["COUNT"] == 25 and res["CONVERGED"] == ok.sum() >= 18
    err = out.loc[ok, ["col", "row"]].to_numpy() - (pts[ok] + SHIFT)
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 0.1
    assert list(out["id"])[:3] == [0, 1, 2]  # the id field option was used
    assert 0 < res["MEDIAN_SIGMA_PX"] < 0.2
    # GeoPackage output loads as a point layer
    res = run("transferpoints", {**params, "OUTPUT": str(tmp_path / "out.gpkg")})
    lyr = QgsVectorLayer(res["OUTPUT"], "t", "ogr")
    assert lyr.isValid() and lyr.featureCount() == 25 and {"sigma_x", "ncc", "status"} <= set(lyr.fields().names())
    # the default field names are not in this table: the tool's message comes through
    with pytest.raises(QgsProcessingException, match="ref_col"):
        run("transferpoints", {"REFERENCE": str(d / "ref.tif"), "SEARCH": str(d / "search.tif"),
                               "POINTS": str(d / "pts.csv"), "OUTPUT": str(tmp_path / "x.csv")})
    with pytest.raises(QgsProcessingException, match=r"OUTPUT must be a \.csv or \.gpkg"):
        run("transferpoints", {**params, "OUTPUT": str(tmp_path / "x.txt")})
    fb = QgsProcessingFeedback()
    fb.progressChanged.connect(lambda v: fb.cancel() if v >= 40 else None)
    with pytest.raises(QgsProcessingException, match="cancelled"):
        run("transferpoints", {**params, "OUTPUT": str(tmp_path / "c.csv")}, fb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "out.gpkg"]


def test_measure_targets(qgis_app, tmp_path):
    import pandas as pd

    from synthetic_images import x_target_scene
    centres = np.array([[60.3, 50.7], [150.55, 120.25], [240.8, 90.4]])
    img = x_target_scene(centres)
    _write(tmp_path / "t.tif", img.astype(np.float32))
    pd.DataFrame({"x": np.round(centres[:, 0]) + 1, "y": np.round(centres[:, 1]) - 1}).to_csv(
        tmp_path / "approx.csv", index=False)
    res = run("measuretargets", {"IMAGE": str(tmp_path / "t.tif"), "POINTS": str(tmp_path / "approx.csv"),
                                 "COL_FIELD": "x", "ROW_FIELD": "y", "POLARITY": 1, "OUTPUT": str(tmp_path / "m.csv")})
    assert res["TARGETS"] == res["MEASURED"] == 3
    m = pd.read_csv(tmp_path / "m.csv")
    assert np.abs(m[["col", "row"]].to_numpy() - centres).max() < 0.05
