"""fotogeo ortho (issue 21): a rendered scene with box buildings (occlusion), the NGI frames and the QuickBird
RPC image (real data), the separable fast paths against the general ones, and bad input."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

import box_scene as bs
from fotogeo.cli import main
from fotogeo.tools.ortho.tool import ortho
from test_bad_input import assert_one_line_error


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return bs.write_scene(tmp_path_factory.mktemp("boxes"))


def _run(scene, out, **kw):
    args = {"dem": str(scene["dsm"]), "camera": str(scene["camera"]), "eo": str(scene["eo"]), "resolution": 0.5, **kw}
    return ortho([str(scene["frame"])], str(out), **args)


def _cells(path):
    """Values and map centres of every cell of a one-band raster."""
    with rasterio.open(path) as ds:
        a, t = ds.read(1), ds.transform
    rows, cols = np.mgrid[0:a.shape[0], 0:a.shape[1]]
    X, Y = t * (cols + 0.5, rows + 0.5)
    return a.ravel(), np.column_stack([X.ravel(), Y.ravel()])


def _truth(XY):
    """Ground cells surely hidden / surely seen (1 m away from every box edge and shadow edge)."""
    hidden = bs.hidden_from_camera(XY, -1.0) & ~bs.on_a_box(XY, 1.0)
    seen = ~bs.hidden_from_camera(XY, 1.0) & ~bs.on_a_box(XY, 1.0)
    return hidden, seen


def test_occluded_ground_is_nodata(scene, tmp_path):
    """Behind each box the ground the camera cannot see is nodata with occlusion masking; without it the same
    cells repeat the roof (the double image). Seen ground matches the rendered texture either way."""
    _run(scene, tmp_path / "plain.tif")
    _run(scene, tmp_path / "masked.tif", occlusion=True)
    plain, XY = _cells(tmp_path / "plain.tif")
    masked, XY2 = _cells(tmp_path / "masked.tif")
    assert np.array_equal(XY, XY2)
    hidden, seen = _truth(XY)
    assert hidden.sum() > 500  # both boxes hide a strip of ground
    assert (plain[hidden] >= bs.WALL).mean() > 0.99  # double image: roof and wall values on hidden ground
    assert (masked[hidden] == 0).mean() > 0.995
    assert (masked[seen] != 0).mean() > 0.999
    tex = bs.texture(XY[:, 0], XY[:, 1])
    ok = seen & (masked != 0)
    assert np.abs(masked[ok] - tex[ok]).mean() < 1.0  # nearest neighbour of a smooth texture: well under 1 grey level
    roofs = bs.on_a_box(XY, -1.0)
    assert (masked[roofs] == bs.ROOF).mean() > 0.99  # roofs on the DSM are where they belong, and seen


def test_triangulate_camera_file_reads_the_same(scene, tmp_path):
    """triangulate's own outputs: a brown camera.yaml (here without distortion) gives the pinhole's orthophoto."""
    brown = tmp_path / "camera.yaml"
    brown.write_text(scene["camera"].read_text().replace("type: pinhole", "type: brown") +
                     "  k1: 0.0\n  k2: 0.0\n  p1: 0.0\n  p2: 0.0\n  k3: 0.0\n")
    _run(scene, tmp_path / "pinhole.tif")
    _run(scene, tmp_path / "brown.tif", camera=str(brown))
    with rasterio.open(tmp_path / "pinhole.tif") as a, rasterio.open(tmp_path / "brown.tif") as b:
        assert np.array_equal(a.read(), b.read())


def test_bare_dem_leaves_the_double_image(scene, tmp_path):
    """On the bare-ground DEM the roofs lean away from the nadir (relief displacement, a displacement of
    height · radius / flying height, 8 m for the first box): with occlusion the ground is all seen (nothing
    rises above it), so nothing is masked."""
    _run(scene, tmp_path / "dem.tif", dem=str(scene["dem"]), occlusion=True)
    v, XY = _cells(tmp_path / "dem.tif")
    assert ((v == bs.ROOF) & ~bs.on_a_box(XY, 1.0)).sum() > 500  # roofs lean off their footprints
    assert (v != 0).mean() > 0.999


def test_each_input_opened_as_often_as_it_is_read(scene, tmp_path, monkeypatch):
    """The frame is opened by its reader (size, bands, type) and by the resampling only: the grid's output check
    takes the bands and type the reader found (it opened the file a third time before)."""
    from collections import Counter
    opened = Counter()
    real = rasterio.open

    def counting(path, *args, **kw):
        opened[str(path)] += 1
        return real(path, *args, **kw)

    monkeypatch.setattr(rasterio, "open", counting)
    _run(scene, tmp_path / "o.tif", resampling="bilinear")
    assert opened[str(scene["frame"])] == 2


def test_pyramid_skips_change_nothing(scene):
    """Rays skipping block-sized stretches above the DSM's block maxima find exactly the occlusions found by
    sampling every half cell (random ground points and directions over the box scene)."""
    from fotogeo.geometry.occlusion import MaxPyramid, hidden
    from fotogeo.io.raster import read_dem
    dsm = read_dem(scene["dsm"])
    rng = np.random.default_rng(1)
    XY = np.column_stack([rng.uniform(-110, 110, 4000) + bs.ORIGIN[0], rng.uniform(-110, 110, 4000) + bs.ORIGIN[1]])
    P = np.column_stack([XY, dsm.heights(XY)])
    d = np.column_stack([rng.normal(size=(4000, 2)), rng.uniform(0.1, 1.0, 4000)])
    plain = hidden(dsm, P, d, step=0.25)
    fast = hidden(dsm, P, d, step=0.25, pyramid=MaxPyramid(dsm))
    assert 200 < plain.sum() < 3800 and np.array_equal(plain, fast)


def test_grid_paths_equal_the_general_ones(scene):
    """The window fast path (DEM per row and column, camera coordinates separable) gives the general path's
    positions, for a pinhole and for a Brown camera (triangulate's camera.yaml)."""
    from affine import Affine

    from fotogeo.io.raster import read_dem
    from fotogeo.io.warp_gdal import centres_to_map
    from fotogeo.tools.ortho.tool import OrthoMapping
    from fotogeo.orientation.adjusted_frame import AdjustedFrame
    f = bs.frame()
    dem = read_dem(scene["dsm"])
    t = Affine(0.5, 0, bs.ORIGIN[0] - 100, 0, -0.5, bs.ORIGIN[1] + 100)
    for dist in ({}, {"k1": -0.08, "k2": 0.01, "p1": 1e-4, "p2": -2e-4, "k3": 0.0}):
        m = OrthoMapping(AdjustedFrame(f.camera, f.eo, dist), dem, (bs.SIZE, bs.SIZE))
        fast, slow = m.grid(t, 13, 27, 64, 96), m(centres_to_map(t, 13, 27, 64, 96))
        fast = fast.reshape(2, -1).T if fast.ndim == 3 else fast  # a frame's grid: two planes (column, row)
        assert np.array_equal(np.isnan(fast), np.isnan(slow))
        assert np.nanmax(np.abs(fast - slow)) < 1e-9


# -- real data -------------------------------------------------------------------------------------------

def _tile_shifts(a, b, valid, tile=128):
    import cv2
    hann = cv2.createHanningWindow((tile, tile), cv2.CV_32F)
    out = []
    for i in range(0, a.shape[0] - tile + 1, tile):
        for j in range(0, a.shape[1] - tile + 1, tile):
            if valid[i:i + tile, j:j + tile].all():
                out.append(cv2.phaseCorrelate(a[i:i + tile, j:j + tile], b[i:i + tile, j:j + tile], hann)[0])
    return np.array(out)


def test_ngi_frame_on_the_ngi_orthophoto(data_dir, tmp_path):
    """NGI frame 0182 orthorectified with its camera, EO and DEM lands on the published orthophoto: median tile
    shift well under a pixel (the data README measures the true geometry at 0.46 px median)."""
    from rasterio.warp import Resampling, reproject
    ngi = data_dir / "ngi"
    out = tmp_path / "0182.tif"
    rep = ortho([str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif")], str(out), dem=str(ngi / "dem.tif"),
                camera=str(ngi / "interior_orientation.yaml"), eo=str(ngi / "exterior_orientation.txt"),
                resolution=5.0, resampling="bilinear")
    assert rep["images"]["3324c_2015_1004_05_0182_RGB"]["dem_coverage"] == 1.0
    assert rep["crs_rule"].startswith("the DEM's CRS")
    with rasterio.open(out) as ds:
        ours, grid = ds.read(1).astype(np.float32), ds.profile
        assert ds.transform.c % 5 == 0 and ds.transform.f % 5 == 0  # aligned to the resolution
    ref = np.zeros_like(ours)
    with rasterio.open(ngi / "ortho" / "ngi_rgb_byte_1.tif") as ds:
        reproject(rasterio.band(ds, 1), ref, dst_transform=grid["transform"], dst_crs=grid["crs"],
                  resampling=Resampling.bilinear, dst_nodata=0)
    s = _tile_shifts(ours, ref, (ours > 0) & (ref > 0))
    assert len(s) >= 15
    med = np.median(np.hypot(s[:, 0], s[:, 1]))
    assert med < 0.6, med
    csv = tmp_path / "ext.csv"  # the same lines as orthority's CSV exterior parameters: the same orthophoto
    csv.write_text((ngi / "exterior_orientation.txt").read_text())
    ortho([str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif")], str(tmp_path / "csv.tif"),
          dem=str(ngi / "dem.tif"), camera=str(ngi / "interior_orientation.yaml"), eo=str(csv), resolution=5.0,
          resampling="bilinear")
    with rasterio.open(tmp_path / "csv.tif") as a, rasterio.open(out) as b:
        assert a.transform == b.transform and np.abs(a.read().astype(int) - b.read()).max() <= 1


def test_orientation_file_in_another_crs_refused(data_dir, tmp_path):
    """orthority's CSV with a .prj stating UTM 35S while the DEM (the map CRS) is the Lo25 TM: mixed CRSs are
    refused by name, not reinterpreted."""
    from pyproj import CRS
    ngi = data_dir / "ngi"
    csv = tmp_path / "ext.csv"
    csv.write_text((ngi / "exterior_orientation.txt").read_text())
    (tmp_path / "ext.prj").write_text(CRS.from_epsg(32735).to_wkt())
    out = tmp_path / "o.tif"
    result = CliRunner().invoke(main, ["ortho", str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif"), "--camera",
                                       str(ngi / "interior_orientation.yaml"), "--eo", str(csv), "--dem",
                                       str(ngi / "dem.tif"), "-o", str(out), "-q"])
    assert_one_line_error(result, "is in EPSG:32735 but the map CRS is")
    assert not out.exists()


def test_dem_read_under_the_images_only(data_dir):
    """Only the DEM window under a frame is read (memory bounded by the frame's ground area), with the heights
    of the whole DEM there."""
    from fotogeo.crs import same_crs
    from fotogeo.io.raster import read_dem
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models, read_dem_under
    ngi = data_dir / "ngi"
    frame = str(ngi / "frames" / "3324c_2015_1004_05_0182_RGB.tif")
    crs, _ = map_crs("auto", str(ngi / "dem.tif"), str(ngi / "exterior_orientation.txt"), [frame], False)
    im = image_models([frame], crs, camera=str(ngi / "interior_orientation.yaml"),
                      eo=str(ngi / "exterior_orientation.txt"))[0]
    part, whole = read_dem_under(ngi / "dem.tif", [im], crs), read_dem(ngi / "dem.tif")
    assert part.data.size < 0.6 * whole.data.size
    assert same_crs(part.crs, whole.crs)  # parsed once (GDAL's parse, no pyproj), carried
    ground = im.model.inverse(np.column_stack([np.linspace(0, 640, 50), np.linspace(0, 1152, 50)]), part)
    assert np.isfinite(ground).all()
    assert np.array_equal(part.heights(ground[:, :2]), whole.heights(ground[:, :2]))


def test_qb2_rpc_against_gdal_transformer(data_dir, tmp_path):
    """The QuickBird image through its vendor RPC on the DEM: output cells sample the pixel GDAL's RPC
    transformer gives for the cell centre at the DEM height (to 0.01 px), and a DEM stating geoid heights is
    refused unless the heights are declared (or shifted by a geoid)."""
    from rasterio.transform import RPCTransformer
    from fotogeo.errors import InputError
    img, dem = data_dir / "qb2" / "qb2_basic1b.tif", data_dir / "ngi" / "dem.tif"
    with pytest.raises(InputError, match="geoid heights but the RPC needs ellipsoid heights"):
        ortho([str(img)], str(tmp_path / "x.tif"), dem=str(dem), rpc=True)
    assert not (tmp_path / "x.tif").exists()
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models, terrain
    crs, _ = map_crs("auto", str(dem), None, [str(img)], True)
    ims = image_models([str(img)], crs, rpc=True)
    heights, ref, _ = terrain(str(dem), None, crs, ims, dem_heights="ellipsoid")
    rng = np.random.default_rng(0)
    XY = np.column_stack([rng.uniform(-58000, -55000, 50), rng.uniform(-3733000, -3726000, 50)])
    Z = heights.heights(XY)
    px = ims[0].model.forward(np.column_stack([XY, Z]))
    from fotogeo.crs import to_lonlat
    ll = to_lonlat(crs, XY)
    with rasterio.open(img) as ds:
        with RPCTransformer(ds.rpcs) as tr:
            rows, cols = tr.rowcol(ll[:, 0], ll[:, 1], zs=Z, op=lambda v: v)
    assert np.nanmax(np.abs(px - np.column_stack([cols, rows]))) < 0.01


def test_geoid_heights_made_ellipsoidal(data_dir, tmp_path):
    """A geoid DEM under an RPC with --geoid: the heights the RPC gets are H + N (a constant N = 30 m here, in a
    lon/lat raster), and --geoid on a DEM said to be ellipsoidal is refused."""
    from affine import Affine
    from fotogeo.errors import InputError
    from fotogeo.tools.ortho.crs_rule import map_crs
    from fotogeo.tools.ortho.inputs import image_models, terrain
    geoid = tmp_path / "n.tif"
    with rasterio.open(geoid, "w", driver="GTiff", width=40, height=40, count=1, dtype="float32", crs="EPSG:4326",
                       transform=Affine(0.05, 0, 23.5, 0, -0.05, -32.7)) as ds:
        ds.write(np.full((1, 40, 40), 30.0, np.float32))
    img, dem = str(data_dir / "qb2" / "qb2_basic1b.tif"), str(data_dir / "ngi" / "dem.tif")
    crs, _ = map_crs("auto", dem, None, [img], True)
    ims = image_models([img], crs, rpc=True)
    shifted, ref, notes = terrain(dem, None, crs, ims, geoid=str(geoid))
    plain, _, _ = terrain(dem, None, crs, ims, dem_heights="ellipsoid")
    XY = np.column_stack([np.linspace(-58000, -55000, 20), np.linspace(-3733000, -3726000, 20)])
    assert ref == "ellipsoid" and np.allclose(shifted.heights(XY), plain.heights(XY) + 30.0)
    with pytest.raises(InputError, match="--geoid .* is given but the heights"):
        terrain(dem, None, crs, ims, dem_heights="ellipsoid", geoid=str(geoid))


# -- bad input ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def bad(scene, tmp_path_factory):
    d = tmp_path_factory.mktemp("ortho_bad")
    with rasterio.open(scene["dsm"]) as ds:
        z, prof = ds.read(1), ds.profile
    holed = z.copy()
    holed[200:210, 200:210] = prof["nodata"]
    with rasterio.open(d / "holes.tif", "w", **prof) as ds:
        ds.write(holed, 1)
    with rasterio.open(d / "half.tif", "w", **{**prof, "width": z.shape[1] // 2}) as ds:
        ds.write(z[:, : z.shape[1] // 2], 1)
    far = prof["transform"] * prof["transform"].translation(100000, 0)
    with rasterio.open(d / "far.tif", "w", **{**prof, "transform": far}) as ds:
        ds.write(z, 1)
    with rasterio.open(d / "nocrs.tif", "w", **{**prof, "crs": None}) as ds:
        ds.write(z, 1)
    (d / "other.txt").write_text(scene["eo"].read_text().replace("frame", "another"))
    from pyproj import Transformer
    name, x, y, *rest = scene["eo"].read_text().split()
    x34, y34 = Transformer.from_crs("EPSG:32635", "EPSG:32634", always_xy=True).transform(float(x), float(y))
    (d / "eo_utm34.txt").write_text(" ".join([name, f"{x34:.3f}", f"{y34:.3f}", *rest]) + "\n")
    return d


def _cli(scene, tmp_path, *extra, dem=None, eo=None):
    out = tmp_path / "o.tif"
    args = ["ortho", str(scene["frame"]), "--camera", str(scene["camera"]), "--eo", str(eo or scene["eo"]),
            "-o", str(out), "-q", *extra]
    if dem is not False:
        args += ["--dem", str(dem or scene["dsm"])]
    return CliRunner().invoke(main, args), out


@pytest.mark.parametrize("case, extra, expected", [
    ("dem far away", {"dem": "far.tif"}, "does not cover image 'frame'"),
    ("no orientation", {"eo": "other.txt"}, "has no orientation for the image(s) frame"),
    ("orientation in another crs than the dem", {"eo": "eo_utm34.txt"}, "are in the same crs"),
    ("no heights", {"dem": False}, "give a dem (--dem) or, knowingly, a constant height"),
    ("dem without crs", {"dem": "nocrs.tif"}, "has no crs"),
    ("dsm with holes", {"dem": "holes.tif", "args": ["--occlusion"]}, "has nodata holes"),
    ("geographic output", {"args": ["--crs", "EPSG:4326"]}, "is geographic"),
    ("uncertainty without a covariance", {"args": ["--uncertainty"]}, "carries no covariance"),
    ("uncertainty of a constant height", {"dem": False, "args": ["--uncertainty", "--height", "100", "--crs",
                                                                 "EPSG:32635"]}, "give its σ (--dem-sigma"),
])
def test_bad_input_one_line(scene, bad, tmp_path, case, extra, expected):
    kw = {k: (bad / v if isinstance(v, str) else v) for k, v in extra.items() if k != "args"}
    result, out = _cli(scene, tmp_path, *extra.get("args", []), **kw)
    assert_one_line_error(result, expected)
    assert not out.exists() and not list(tmp_path.glob(".*"))


def test_failed_run_leaves_no_folder(scene, tmp_path):
    """Two images into a new folder, one without a pose: the error names it and the folder is gone again."""
    import shutil
    second = tmp_path / "frame2.tif"
    shutil.copy(scene["frame"], second)
    out = tmp_path / "orthos"
    result = CliRunner().invoke(main, ["ortho", str(scene["frame"]), str(second), "--camera", str(scene["camera"]),
                                       "--eo", str(scene["eo"]), "--dem", str(scene["dsm"]), "-o", str(out), "-q"])
    assert_one_line_error(result, "no orientation for the image(s) frame2")
    assert not out.exists()


def test_partial_dem_clips_and_names_the_coverage(scene, bad, tmp_path):
    result, out = _cli(scene, tmp_path, "--json", dem=bad / "half.tif")  # -q hides the warnings, --json keeps them
    assert result.exit_code == 0, result.output
    warn = json.loads(result.stdout)["warnings"]
    assert any("covers 4" in w or "covers 5" in w for w in warn), warn  # about half the frame
    with rasterio.open(out) as ds, rasterio.open(bad / "half.tif") as dem:
        assert ds.bounds.right <= dem.bounds.right + 0.5


def test_warnings_are_output_whatever_the_interpreter_filters(scene, bad, tmp_path):
    """fotogeo's warnings are the run's output: ``python -W ignore`` / ``PYTHONWARNINGS=ignore`` (a global
    "ignore" filter) does not hide them from the console nor from ``--json``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result, _ = _cli(scene, tmp_path, "--json", dem=bad / "half.tif")
    assert result.exit_code == 0, result.output
    assert any("covers 4" in w or "covers 5" in w for w in json.loads(result.stdout).get("warnings", [])), result.output


def test_dem_holes_without_occlusion_warn(scene, bad, tmp_path):
    """Without occlusion masking a DEM with holes still orthorectifies; the warning says the holes are nodata."""
    result, out = _cli(scene, tmp_path, "--resolution", "0.5", "--json", dem=bad / "holes.tif")
    assert result.exit_code == 0, result.output
    assert any("has nodata holes" in ln for ln in json.loads(result.stdout)["warnings"] if ln.startswith("Warning:"))
    v, XY = _cells(out)
    _run(scene, tmp_path / "whole.tif")
    w, XY2 = _cells(tmp_path / "whole.tif")
    assert np.array_equal(XY, XY2)
    lost = (v == 0) & (w != 0)
    assert 100 <= lost.sum() <= 196  # the 10 x 10-cell hole, grown by the bilinear neighbourhood (<= 14 x 14)


def test_rpc_without_dem_needs_a_constant_height(data_dir, tmp_path):
    img = data_dir / "qb2" / "qb2_basic1b.tif"
    out = tmp_path / "q.tif"
    result = CliRunner().invoke(main, ["ortho", str(img), "--rpc", "-o", str(out), "-q"])
    assert_one_line_error(result, "rpc image(s) qb2_basic1b: orthorectification needs heights")
    assert not out.exists()
    result = CliRunner().invoke(main, ["ortho", str(img), "--rpc", "--height", "300", "--resolution", "6", "-o",
                                       str(out), "-q"])
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 32735  # the UTM zone of the image centre


def test_view_bands_on_a_nadir_frame_over_flat_ground(scene, tmp_path):
    """--view-bands on the bare ground under the nadir frame 500 m up: off-nadir angle atan(r / 500) and distance
    √(r² + 500²) at horizontal distance r from the nadir point; NaN where the image does not reach."""
    rep = _run(scene, tmp_path / "o.tif", dem=str(scene["dem"]), view_bands=True)
    path = rep["images"]["frame"]["view"]["path"]
    with rasterio.open(path) as ds, rasterio.open(tmp_path / "o.tif") as o:
        assert (ds.count, ds.units, ds.transform) == (2, ("deg", "m"), o.transform)
        angle, dist, t = ds.read(1), ds.read(2), ds.transform
    rows, cols = np.mgrid[0:angle.shape[0], 0:angle.shape[1]]
    X, Y = t * (cols + 0.5, rows + 0.5)
    r = np.hypot(X - bs.ORIGIN[0], Y - bs.ORIGIN[1])
    ok = np.isfinite(angle)
    assert ok.mean() > 0.9 and np.isfinite(dist[ok]).all()
    np.testing.assert_allclose(angle[ok], np.degrees(np.arctan(r[ok] / bs.FLY)), atol=1e-4)
    np.testing.assert_allclose(dist[ok], np.hypot(r[ok], bs.FLY), rtol=1e-6)
    assert angle[ok].max() > 10  # the frame's corners: 0.2 / 1 · √2 off the axis → 15.8°
