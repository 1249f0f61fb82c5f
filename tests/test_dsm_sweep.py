"""What a new user's sweep of ``fotogeo dsm`` found (session 18): outputs named for another format, two outputs at
one path, ``--rpc`` beside a frame orientation, ``--bounds`` off the overlap and a grid too coarse to keep any
height, a match density above 100 %, and blank frames without a DEM — each refused up front in one line naming
the option, or reported right.

A rendered 256² pair (``tests/rendered_pair.py``, 0.1 m GSD, B/H 0.4) where images are needed; the refusals that
come before any image is read use blank stand-ins.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fotogeo.errors import InputError, OutputError

CRS = "EPSG:32635"


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    from rendered_pair import render
    return render(tmp_path_factory.mktemp("pair"), 256)


def _blank(folder: Path) -> list:
    import rasterio
    paths = [folder / f"{n}.tif" for n in ("left", "right")]
    for p in paths:
        with rasterio.open(p, "w", driver="GTiff", width=32, height=32, count=1, dtype="uint8") as ds:
            ds.write(np.zeros((1, 32, 32), np.uint8))
    return paths


@pytest.mark.parametrize("name,kw,words", [
    ("d.jpg", {}, r"DSM '.*d\.jpg': fotogeo writes it as GeoTIFF; give a file name ending in \.tif"),
    ("d.las", {}, r"DSM '.*d\.las': fotogeo writes it as GeoTIFF"),
    ("d.tif", {"point_cloud": "p.txt"}, r"point cloud '.*p\.txt': fotogeo writes it as LAS or LAZ"),
    ("d.tif", {"report": "d.tif"}, r"report '.*d\.tif' is also the DSM; give each output its own file name"),
])
def test_outputs_are_checked_before_any_image_is_read(tmp_path, name, kw, words):
    """Before: a GeoTIFF written under .jpg or .las with exit 0; a report at the DSM's path found only after the
    whole run ("appeared while fotogeo was working")."""
    from fotogeo.tools.dsm import dsm
    images = _blank(tmp_path)
    kw = {k: tmp_path / v for k, v in kw.items()}
    with pytest.raises(OutputError, match=words):
        dsm(images, tmp_path / name, rpc=True, **kw)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["left.tif", "right.tif"]


def test_triangulate_refuses_a_dsm_named_for_another_format(pair, tmp_path):
    from fotogeo.tools.triangulate import triangulate
    with pytest.raises(OutputError, match=r"DSM '.*d\.jpg': fotogeo writes it as GeoTIFF"):
        triangulate(pair["images"], pair["camera"], pair["eo"], None, tmp_path / "block", crs=CRS,
                    dsm=tmp_path / "d.jpg")


def test_rpc_beside_a_frame_orientation_is_refused(pair, tmp_path):
    """Before: --rpc with --eo ran the RPC path and ignored --eo without a word."""
    from fotogeo.tools.dsm import dsm
    with pytest.raises(InputError, match=r"give either --rpc or the frames' orientation \(--eo\)"):
        dsm(pair["images"], tmp_path / "d.tif", rpc=True, eo=pair["eo"])


def test_bounds_off_the_overlap_and_a_grid_too_coarse_are_named(pair, tmp_path):
    """Before: both ran the matching and ended in "no height was matched in any pair: the images may be
    textureless or cloud-covered"."""
    from fotogeo.tools.dsm import dsm
    kw = dict(camera=pair["camera"], eo=pair["eo"], crs=CRS)
    with pytest.raises(InputError, match=r"--bounds 0,0,100,100 lies outside the images' stereo overlap "
                                         r"\(4999\d\d\.\d\d,"):
        dsm(pair["images"], tmp_path / "a.tif", bounds="0,0,100,100", **kw)
    with pytest.raises(InputError, match=r"--resolution 1000 makes a DSM of \d x \d cells .*fewer than 64 cells"):
        dsm(pair["images"], tmp_path / "b.tif", resolution=1000, **kw)
    assert not list(tmp_path.iterdir())


def test_the_match_density_is_a_share_of_the_matchable_pixels(pair, tmp_path):
    """Before: pixels matched outside the matchable ones were counted too, so the density could exceed 100 %; now
    the rendered 256² pair's is a share of its matchable pixels."""
    from fotogeo.tools.dsm import dsm
    rep = dsm(pair["images"], tmp_path / "a.tif", camera=pair["camera"], eo=pair["eo"], crs=CRS)
    density = rep["pairs"][0]["match_density"]
    assert 0.5 < density <= 1.0, density


def test_blank_frames_without_a_dem_are_called_textureless(pair, tmp_path):
    """Before: "only 0 sparse matches; the heights cannot be bounded from them: give a coarse DEM" — a DEM does
    not make blank frames match."""
    import rasterio

    from fotogeo.tools.dsm import dsm
    blank = []
    for p in pair["images"]:
        with rasterio.open(p) as src:
            prof = src.profile
        q = tmp_path / Path(p).name
        with rasterio.open(q, "w", **prof) as dst:
            dst.write(np.full((1, prof["height"], prof["width"]), 128, np.uint8))
        blank.append(q)
    with pytest.raises(InputError, match=r"only 0 sparse matches \(textureless or cloud-covered"):
        dsm(blank, tmp_path / "a.tif", camera=pair["camera"], eo=pair["eo"], crs=CRS)


def test_a_dsm_with_holes_for_occlusion_points_to_dsm_fill(pair, tmp_path):
    """Before: "fill them first (gdal_fillnodata.py)" — fotogeo's own DSM has holes by default, and ``dsm --fill``
    is the fill of the chain ``dsm`` → ``ortho --occlusion``."""
    import rasterio
    from rasterio.transform import from_origin

    from fotogeo.tools.ortho import ortho
    dem = tmp_path / "dsm.tif"
    z = np.zeros((60, 60), np.float32)
    z[30, 30] = -32767.0
    with rasterio.open(dem, "w", driver="GTiff", width=60, height=60, count=1, dtype="float32", crs=CRS,
                       transform=from_origin(499980.0, 4420030.0, 1.0, 1.0), nodata=-32767.0) as ds:
        ds.write(z[None])
    with pytest.raises(InputError, match=r"has nodata holes .*fill them first \(fotogeo dsm --fill, which fills 4 "
                                         r"cells from the data unless --fill-max-distance reaches farther; or "):
        ortho(pair["images"][:1], tmp_path / "o.tif", camera=pair["camera"], eo=pair["eo"], dem=dem, occlusion=True,
              dst_crs=CRS)


def test_filled_holes_stay_within_the_heights_around_them():
    """``--fill``: OpenCV's Telea inpainting on float32 overshot far beyond the data (a 0.5–9.9 m ramp's hole came
    out −8.8 to 18.4 m, RMSE 8.8 m; the rendered 400² pair's filled cells RMSE 13.4 m, 25 m at worst); in 16 bits
    the hole follows the ramp (RMSE 0.24 m)."""
    from fotogeo.stereo.fusion import fill_holes
    x = np.mgrid[0:100, 0:100][1].astype(np.float32)
    h = 0.1 * x
    h[40:60, 40:60] = np.nan
    out, mask = fill_holes(h)
    filled = out[mask == 1]
    assert mask.sum() == 400 and filled.min() >= 0.0 and filled.max() <= 9.9
    assert np.sqrt(np.mean((filled - 0.1 * x[mask == 1]) ** 2)) < 0.5


def test_fill_leaves_the_completeness_of_the_matched_cells(pair, tmp_path):
    """The cells both images see were found on the filled heights, so the same matched cells gave another
    completeness with ``--fill`` than without; now both count the cells seen at the matched heights."""
    from fotogeo.tools.dsm import dsm
    kw = dict(camera=pair["camera"], eo=pair["eo"], crs=CRS)
    plain = dsm(pair["images"], tmp_path / "a.tif", **kw)
    filled = dsm(pair["images"], tmp_path / "b.tif", fill=True, **kw)
    assert filled["filled_cells"] > 0
    assert filled["completeness"] == plain["completeness"] and filled["stereo_cells"] == plain["stereo_cells"]


@pytest.mark.data
def test_an_rpc_that_does_not_fit_its_image_is_named_when_nothing_matches(data_dir, tmp_path):
    """Ventoux's left image turned 90° beside its .geom: a 172 px relative pointing error, then "no height was
    matched in any pair: the images may be textureless or cloud-covered" — the images are neither."""
    import shutil

    import rasterio

    from fotogeo.tools.dsm import dsm
    v = data_dir / "rpc" / "ventoux"
    with rasterio.open(v / "left_image.tif") as src:
        prof, a = src.profile, src.read()
    with rasterio.open(tmp_path / "left.tif", "w", **prof) as dst:
        dst.write(np.ascontiguousarray(np.rot90(a, axes=(1, 2))))
    shutil.copy(v / "left_image.geom", tmp_path / "left.geom")
    shutil.copy(v / "right_image.tif", tmp_path / "right.tif")
    shutil.copy(v / "right_image.geom", tmp_path / "right.geom")
    with pytest.raises(InputError, match=r"RPCs may not describe their pixels: the relative pointing error was large "
                                         r"for left-right \(\d+ px\) \(an image rotated"):
        dsm([tmp_path / "left.tif", tmp_path / "right.tif"], tmp_path / "d.tif", rpc=True)


@pytest.mark.data
def test_an_rpc_dsm_refuses_a_crs_with_a_vertical_part(data_dir, tmp_path):
    """Before: ``--crs EPSG:32631+5773`` (UTM + EGM96 height) gave the ellipsoidal heights under a plain EPSG:32631,
    exit 0 — off the EGM96 heights asked for by the geoid's height at Ventoux."""
    from fotogeo.tools.dsm import dsm
    v = data_dir / "rpc" / "ventoux"
    with pytest.raises(InputError, match=r"crs 'EPSG:32631\+5773' has a vertical part \(EGM96 height\).*above the "
                                         r"ellipsoid"):
        dsm([v / "left_image.tif", v / "right_image.tif"], tmp_path / "d.tif", rpc=True, crs="EPSG:32631+5773")
    assert not list(tmp_path.iterdir())


def test_cameras_outside_the_given_crs_area_of_use_are_named(pair, tmp_path):
    """Before: positions read in a CRS they are not in made a DSM where they then fall, exit 0, without a word (NGI's
    Lo25 positions as EPSG:32735: −144° E; the rendered pair's UTM 35N positions as Lambert-93: 27° N, south of
    France)."""
    from fotogeo.errors import FotogeoWarning
    from fotogeo.tools.dsm import dsm
    with pytest.warns(FotogeoWarning, match=r"--crs EPSG:2154: camera 'r256_a' at \(500000, 4420000\) lies at "
                                            r"1.08° E, 27.16° N, outside the CRS's area of use"):
        dsm(pair["images"], tmp_path / "a.tif", camera=pair["camera"], eo=pair["eo"], crs="EPSG:2154")


def test_cells_outside_the_hull_are_never_read_as_heights():
    """The NaN cells left unfilled (outside the convex hull of the data) were outside the inpainting mask, so Telea
    read them as the lowest height (NGI at 12 m: ``benchmarks/dsm_fill_bench.py``); here a hole cut by the hull's
    edge in a 1000–1099 m ramp was pulled down towards 1000."""
    from fotogeo.stereo.fusion import fill_holes
    rows, cols = np.mgrid[0:100, 0:100].astype(np.float32)
    h = 1000 + cols
    h[rows > cols] = np.nan  # the data: the upper-right triangle; its hull ends on the diagonal
    h[40:60, 45:70] = np.nan  # a hole touching the diagonal
    out, mask = fill_holes(h)
    filled = mask == 1
    err = out[filled] - (1000 + cols[filled])  # fixed: RMSE 2.8, max 7.5 (Telea's own); before: RMSE 26, max 56
    assert filled.sum() > 300 and np.sqrt(np.mean(err ** 2)) < 4 and np.abs(err).max() < 10
