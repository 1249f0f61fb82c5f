"""Bands for matching (issue 19): reference_bands / target_bands, empty and constant bands left out of
the PCA with a warning, band numbers out of range refused with the flag and the valid range."""
import json
import warnings

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.image.fusion import band_content, pca_fuse
from fotogeo.tools.register.match import band_numbers, match_images, select_bands
from fotogeo.tools.register.tool import register
from synthetic_pair import make_landsat_pair


@pytest.fixture(scope="module")
def landsat(data_dir, tmp_path_factory):
    """The Landsat warp pair of tests/synthetic_pair.py, and a Landsat-8-style 5-band reference:
    the three RGB bands, a constant band (4) and an empty band (5: all 0 = nodata)."""
    folder = tmp_path_factory.mktemp("bands")
    ref, tgt, H = make_landsat_pair(data_dir / "landsat_rgb" / "RGB.byte.tif", folder)
    with rasterio.open(ref) as ds:
        rgb, profile = ds.read(), ds.profile
    five = folder / "five_bands.tif"
    profile.update(count=5, driver="GTiff")
    with rasterio.open(five, "w", **profile) as ds:
        ds.write(np.concatenate([rgb, np.full((1, *rgb.shape[1:]), 77, np.uint8), np.zeros((1, *rgb.shape[1:]),
                                                                                        np.uint8)]))
    return ref, tgt, five


def test_pca_leaves_empty_and_constant_bands_out_with_a_warning(rng):
    base = rng.normal(100, 20, (40, 50))
    bands = np.stack([base, np.full((40, 50), 7.0), base * 0.5 + 3, np.full((40, 50), np.nan)])
    with pytest.warns(FotogeoWarning, match=r"image: bands 2 \(constant 7\), 4 \(empty\) left out of the PCA"):
        f = pca_fuse(bands)
    assert f.bands == (1, 3) and f.dropped == {2: "constant 7", 4: "empty"}
    assert f.component[[1, 3]].tolist() == [0.0, 0.0] and (f.component[[0, 2]] > 0).all()
    assert f.mask.all()  # an all-NaN band no longer voids every pixel
    assert np.corrcoef(f.image.ravel(), base.ravel())[0, 1] > 0.99
    # band numbers as named by the caller, per-band masks
    mask = np.ones((4, 40, 50), bool)
    mask[2] = False
    with pytest.warns(FotogeoWarning, match=r"bands 12 \(constant 7\), 13 \(empty\), 14 \(empty\)"):
        g = pca_fuse(bands, mask, numbers=(11, 12, 13, 14))
    assert g.bands == (11,) and g.explained == 1.0


def test_pca_refuses_only_an_image_without_a_band_left():
    assert band_content(np.zeros((2, 5, 5), np.uint8), nodata=0) == {1: "empty", 2: "empty"}
    with pytest.raises(InputError, match="no valid pixels in any band"):
        pca_fuse(np.zeros((2, 5, 5), np.uint8), nodata=0)
    with pytest.raises(InputError, match=r"every band is constant or empty \(1 \(constant 3\), 2 \(empty\)\)"):
        pca_fuse(np.stack([np.full((5, 5), 3.0), np.full((5, 5), np.nan)]), name="x")


@pytest.mark.parametrize("value, numbers", [("1,2,3", (1, 2, 3)), (" 4 , 2", (4, 2)), ("3 1", (3, 1)), (2, (2,)),
                                            ((5, 1), (5, 1)), (None, None), ("", None)])
def test_band_numbers(value, numbers):
    assert band_numbers(value, "reference_bands") == numbers


@pytest.mark.parametrize("value, message", [
    ("1,x", "--target-bands '1,x': give band numbers from 1"), ("0", "--target-bands '0': give band numbers from 1"),
    ("1.5", "give band numbers from 1"), ((1, 2.0), "give band numbers from 1"), (True, "give band numbers"),
    ("2,2", "band 2 given twice"),
])
def test_band_numbers_refused(value, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(".", r"\.")):
        band_numbers(value, "target_bands")


def test_band_range_names_the_flag_and_the_valid_range():
    assert select_bands(None, 3, "target") == (1, 2, 3)
    with pytest.raises(InputError, match=r"^--reference-bands 5: the reference has 3 bands \(1-3\)"):
        select_bands("5", 3, "reference")
    with pytest.raises(InputError, match=r"^--target-bands 1,2: the target has 1 band \(1\)"):
        select_bands((1, 2), 1, "target")


def test_a_landsat8_style_reference_with_constant_and_empty_bands_registers(landsat, tmp_path):
    """Before: "no valid pixels" — GDAL's per-band nodata masks, ANDed, voided every pixel."""
    _, tgt, five = landsat
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        r = register(five, tgt, tmp_path / "o.tif", seed=1)
    msgs = [str(w.message) for w in seen if issubclass(w.category, FotogeoWarning)]
    assert any("bands 4 (constant 77), 5 (empty) left out of the PCA" in m for m in msgs), msgs
    rep = r.report
    assert rep["bands_fused"] == {"reference": [1, 2, 3], "target": [1, 2, 3]}
    assert rep["bands_left_out"] == {"reference": {"4": "constant 77", "5": "empty"}}
    assert rep["check"]["rmse_px"] < 0.5 and rep["inliers"] > 100


def test_bands_select_what_is_matched_and_the_output_keeps_every_band(landsat, tmp_path):
    ref, tgt, five = landsat
    r = register(five, tgt, tmp_path / "o.tif", reference_bands="3,1", target_bands=(2,), seed=1)
    rep = json.loads((tmp_path / "o.json").read_text())
    assert rep["options"]["reference_bands"] == "3,1" and rep["options"]["target_bands"] == "2"
    assert rep["bands_fused"] == {"reference": [3, 1], "target": [2]} and "bands_left_out" not in rep
    assert r.report["check"]["rmse_px"] < 0.5
    with rasterio.open(tmp_path / "o.tif") as ds:
        assert ds.count == 3  # the target's three bands, resampled
    out = match_images(ref, tgt, tmp_path / "m.gpkg", target_bands="1")
    assert out["bands_fused"] == {"reference": [1, 2, 3], "target": [1]} and out["inliers"] > 100


def test_bands_out_of_range_refused_before_any_output(landsat, tmp_path):
    ref, tgt, _ = landsat
    with pytest.raises(InputError, match=r"--reference-bands 5: the reference has 3 bands \(1-3\)"):
        register(ref, tgt, tmp_path / "o.tif", reference_bands="5")
    with pytest.raises(InputError, match=r"--target-bands 1,4: the target has 3 bands \(1-3\)"):
        register(ref, tgt, tmp_path / "o.tif", target_bands="1,4")
    with pytest.raises(InputError, match="--target-bands 'a': give band numbers"):
        register(ref, tgt, tmp_path / "o.tif", target_bands="a")
    assert list(tmp_path.iterdir()) == []


def test_cli_band_flags(landsat, tmp_path):
    from fotogeo.cli import main
    ref, tgt, five = landsat
    run = CliRunner().invoke
    r = run(main, ["register", str(ref), str(tgt), "-o", str(tmp_path / "o.tif"), "-q", "--reference-bands", "5"])
    assert r.exit_code == 2 and "Error: --reference-bands 5: the reference has 3 bands (1-3)" in r.output
    r = run(main, ["register", str(five), str(tgt), "-o", str(tmp_path / "o.tif"), "-q", "--reference-bands",
                   "1,2,3", "--target-bands", "3,2,1"])
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "o.json").read_text())["bands_fused"] == {"reference": [1, 2, 3],
                                                                             "target": [3, 2, 1]}
