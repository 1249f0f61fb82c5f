"""The area-based matching tools and their CLI: GCP transfer and X-target measurement."""
import numpy as np
import pandas as pd
import pytest
import rasterio
from click.testing import CliRunner

from fotogeo.cli import main
from synthetic_images import x_target_scene
from fotogeo.errors import OutputError, VectorError
from fotogeo.tools.points.targets import measure_targets
from fotogeo.tools.points.transfer import transfer_gcps


def _write(path, img):
    img = np.asarray(img)
    with rasterio.open(path, "w", driver="GTiff", width=img.shape[-1], height=img.shape[-2], count=1,
                       dtype=img.dtype) as ds:
        ds.write(img.reshape(1, *img.shape[-2:]))


def test_transfer_recovers_a_known_subpixel_shift(data_dir, tmp_path):
    """The search image is the reference shifted by (3.4, -2.3) px with an exact Fourier shift."""
    with rasterio.open(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        ref = ds.read(2, window=((300, 556), (200, 456))).astype(np.float64)
    shift = np.array([3.4, -2.3])
    fy, fx = np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij")
    search = np.real(np.fft.ifft2(np.fft.fft2(ref) * np.exp(-2j * np.pi * (fx * shift[0] + fy * shift[1]))))
    _write(tmp_path / "ref.tif", ref.astype(np.float32))
    _write(tmp_path / "search.tif", search.astype(np.float32))
    rng = np.random.default_rng(1)
    pts = rng.uniform(60, 196, (25, 2))
    pd.DataFrame({"id": range(25), "ref_col": pts[:, 0], "ref_row": pts[:, 1], "col": np.round(pts[:, 0]),
                  "row": np.round(pts[:, 1])}).to_csv(tmp_path / "pts.csv", index=False)
    r = transfer_gcps(tmp_path / "ref.tif", tmp_path / "search.tif", tmp_path / "pts.csv", tmp_path / "out.csv")
    out = pd.read_csv(tmp_path / "out.csv")
    ok = out.status == "converged"
    assert ok.sum() >= 18 and r["converged"] == ok.sum()
    err = out.loc[ok, ["col", "row"]].to_numpy() - (pts[ok.to_numpy()] + shift)
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 0.1
    assert (out.loc[ok, "sigma_x"] < 0.2).all()
    with pytest.raises(OutputError, match="overwrite"):
        transfer_gcps(tmp_path / "ref.tif", tmp_path / "search.tif", tmp_path / "pts.csv", tmp_path / "out.csv")
    pd.DataFrame({"a": [1]}).to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(VectorError, match="ref_col"):
        transfer_gcps(tmp_path / "ref.tif", tmp_path / "search.tif", tmp_path / "bad.csv", tmp_path / "o2.csv")


def test_measure_targets_cli(tmp_path):
    centres = np.array([[60.3, 50.7], [150.55, 120.25], [240.8, 90.4]])
    img = x_target_scene(centres)
    _write(tmp_path / "t.tif", img.astype(np.float32))
    pd.DataFrame({"col": np.round(centres[:, 0]) + 1, "row": np.round(centres[:, 1]) - 1}).to_csv(
        tmp_path / "approx.csv", index=False)
    res = CliRunner().invoke(main, ["measure-targets", str(tmp_path / "t.tif"), str(tmp_path / "approx.csv"),
                                    "-o", str(tmp_path / "m.csv"), "-q"])
    assert res.exit_code == 0, res.output
    m = pd.read_csv(tmp_path / "m.csv")
    assert np.abs(m[["col", "row"]].to_numpy() - centres).max() < 0.05
    r = measure_targets(tmp_path / "t.tif", tmp_path / "approx.csv", tmp_path / "m.gpkg")
    assert r["measured"] == 3


def _crop(src, dst, window):
    from rasterio.windows import Window
    with rasterio.open(src) as ds:
        prof = ds.profile
        prof.update(width=window[2], height=window[3], transform=ds.window_transform(Window(*window)))
        with rasterio.open(dst, "w", **prof) as out:
            out.write(ds.read(window=Window(*window)))
    return dst


def test_match_flags_no_chance_inliers_between_unrelated_images(data_dir, tmp_path):
    """The NGI valley against the Bahamas (Landsat): 215 ratio-0.95 matches, all wrong. On main RANSAC's
    5-point minimum flagged 6 of them homography inliers (exit 0, a plausible tie-point layer); now fewer than
    12 agreeing matches flag none, and a warning names both files."""
    import warnings
    from fotogeo.errors import FotogeoWarning
    from fotogeo.tools.register.match import match_images
    a = _crop(data_dir / "ngi" / "ortho" / "ngi_rgb_byte_1.tif", tmp_path / "a.tif", (200, 300, 500, 500))
    b = _crop(data_dir / "landsat_rgb" / "RGB.byte.tif", tmp_path / "b.tif", (150, 100, 500, 500))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = match_images(a, b, tmp_path / "t.gpkg", ratio=0.95)
    assert r["matches"] > 100 and r["inliers"] == 0
    said = [str(w.message) for w in caught if issubclass(w.category, FotogeoWarning)]
    assert any("agree on one homography" in m and "a.tif" in m and "b.tif" in m for m in said), said


def test_point_tables_named_for_another_format_are_refused(tmp_path):
    """measure-targets -o t.txt wrote a GeoPackage named .txt on main (exit 0); CSV or GeoPackage by name now."""
    centres = np.array([[60.3, 50.7], [150.55, 120.25]])
    _write(tmp_path / "t.tif", x_target_scene(centres).astype(np.float32))
    pd.DataFrame({"col": centres[:, 0], "row": centres[:, 1]}).to_csv(tmp_path / "approx.csv", index=False)
    with pytest.raises(OutputError, match="fotogeo writes it as CSV or GeoPackage; give a file name ending in .csv"):
        measure_targets(tmp_path / "t.tif", tmp_path / "approx.csv", tmp_path / "m.txt")
    assert not (tmp_path / "m.txt").exists()


def test_transfer_into_a_turned_search_image_says_none_converged(tmp_path):
    """A search image turned 90° (as a user's other-date frame may be): no point converges. On main the run
    printed 'median σ None px' and nothing else; now a warning says what area-based matching needs, and the
    σ of a good run reads in three decimals."""
    rng = np.random.default_rng(3)
    from scipy.ndimage import gaussian_filter
    ref = gaussian_filter(rng.normal(0, 1, (200, 200)), 2.0).astype(np.float32)
    _write(tmp_path / "ref.tif", ref)
    _write(tmp_path / "turned.tif", np.rot90(ref, -1).copy())
    pts = rng.uniform(50, 150, (8, 2))
    pd.DataFrame({"id": range(8), "ref_col": pts[:, 0], "ref_row": pts[:, 1], "col": pts[:, 0],
                  "row": pts[:, 1]}).to_csv(tmp_path / "pts.csv", index=False)
    r = CliRunner().invoke(main, ["transfer-points", str(tmp_path / "ref.tif"), str(tmp_path / "turned.tif"),
                                  str(tmp_path / "pts.csv"), "-o", str(tmp_path / "t.csv")])  # no -q: it hides warnings
    assert r.exit_code == 0 and "0 of 8 points converged (no σ)" in r.output, r.output
    assert "none of the 8 points converged in" in r.stderr and "orientation and scale" in r.stderr
    r = CliRunner().invoke(main, ["transfer-points", str(tmp_path / "ref.tif"), str(tmp_path / "ref.tif"),
                                  str(tmp_path / "pts.csv"), "-o", str(tmp_path / "same.csv"), "-q"])
    assert r.exit_code == 0 and "8 of 8 points converged (median σ 0.0" in r.output, r.output


@pytest.mark.parametrize("command", ["measure-targets", "transfer-points"])
def test_duplicate_point_ids_are_refused_by_name(tmp_path, command):
    """Two rows with id T2 (a copy-paste in the approximate positions): on main both were measured and written
    under one id, so a join on the id kept one silently; now the table is refused naming the ids, rows and file."""
    centres = np.array([[60.3, 50.7], [150.55, 120.25], [240.8, 90.4], [100.2, 140.6]])
    _write(tmp_path / "t.tif", x_target_scene(centres).astype(np.float32))
    table = pd.DataFrame({"id": ["T1", "T2", "T3", "T2"], "col": np.round(centres[:, 0]),
                          "row": np.round(centres[:, 1]), "ref_col": centres[:, 0], "ref_row": centres[:, 1]})
    table.to_csv(tmp_path / "approx.csv", index=False)
    images = [tmp_path / "t.tif"] * (1 if command == "measure-targets" else 2)
    r = CliRunner().invoke(main, [command, *map(str, images), str(tmp_path / "approx.csv"),
                                  "-o", str(tmp_path / "m.csv")])
    assert r.exit_code == 1 and "approx.csv" in r.stderr, r.output
    assert "id(s) used more than once in field 'id': 'T2' (rows 2, 4); give each point its own id" in r.stderr
    assert not (tmp_path / "m.csv").exists()
