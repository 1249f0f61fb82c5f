"""GCP pixels read on a resized or turned copy of the image reach every command reading GCP pixels (issue 32):
``compare-models`` with a camera, ``rpc-bias`` with the affine correction and ``triangulate --gcps`` (each frame's
measurements) run ``orient``'s one check (:func:`fotogeo.tools.common.checks.copy_check`). Before, each took positions
read on a 0.5x / 0.25x / quarter-turned copy as given, with exit 0: compare-models filled its table with the
free-scale models' plausible rows, the affine RPC correction absorbed the copy's scale or turn, and triangulate
started the block from them. The right image and a crop with an offset (its own camera, or the RPC moved into it)
are fitted as before."""
import shutil

import geopandas as gpd
import numpy as np
import pytest
import rasterio
import shapely
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.errors import InputError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.io.camera import load_ngi_frame
from fotogeo.io.raster import read_dem
from fotogeo.orientation.simulation import make_gcps
from test_bad_input import assert_one_line_error

W, H = 640, 1152
FRAMES = ("3324c_2015_1004_05_0182", "3324c_2015_1004_05_0184")
#: the copies: what was done to the image the GCPs were measured on, and the words the refusal names it by
COPIES = {"x0.5": (lambda p: p * 0.5, "a copy about 0.5x this image's size"),
          "x0.25": (lambda p: p * 0.25, "a copy about 0.25x this image's size"),
          "turned": (lambda p: np.column_stack([H - p[:, 1], p[:, 0]]), "a copy of this image turned")}
#: the crop with an offset: its top-left corner in the frame, its size
OFFSET, CROP = (100, 200), (320, 576)


@pytest.fixture(scope="module")
def ngi(data_dir):
    """Per NGI frame: 30 control + 10 check points of its true geometry (camera, published EO, DEM), 0.3 px noise."""
    ngi = data_dir / "ngi"
    dem = read_dem(ngi / "dem.tif")
    sets = {}
    for k, name in enumerate(FRAMES):
        s = make_gcps(load_ngi_frame(ngi, name), dem, 30, 10, "homogeneous", noise=0.3, seed=7 + k)
        sets[name] = (np.vstack([s.gcp_ground, s.check_ground]), np.vstack([s.gcp_pixel, s.check_pixel]))
    return {"dir": ngi, "sets": sets, "crs": dem.crs.to_wkt(), "camera": str(ngi / "interior_orientation.yaml")}


def _layer(path, ground, pixel, crs, frame=None, prefix="P"):
    cols = {"id": [f"{prefix}{i}" for i in range(len(pixel))], "col": pixel[:, 0], "row": pixel[:, 1],
            "z": ground[:, 2], "role": ["control"] * 30 + ["check"] * (len(pixel) - 30)}
    if frame is not None:
        cols["frame"] = [frame] * len(pixel)
    gpd.GeoDataFrame(cols, geometry=shapely.points(ground[:, :2]), crs=crs).to_file(path, driver="GPKG")
    return path


def _crop(src, dst):
    """The frame's pixels ``OFFSET`` .. ``OFFSET + CROP`` as their own (ungeoreferenced) raster."""
    with rasterio.open(src) as ds:
        a = ds.read(window=rasterio.windows.Window(*OFFSET, *CROP))
    with rasterio.open(dst, "w", driver="GTiff", width=CROP[0], height=CROP[1], count=a.shape[0],
                       dtype=a.dtype) as out:
        out.write(a)
    return dst


# -- compare-models with a camera ----------------------------------------------------------------------------------
@pytest.mark.parametrize("case", list(COPIES))
def test_compare_models_refuses_pixels_read_on_a_copy(ngi, tmp_path, case):
    from fotogeo import compare_models
    ground, pixel = ngi["sets"][FRAMES[0]]
    read, said = COPIES[case]
    path = _layer(tmp_path / "g.gpkg", ground, read(pixel), ngi["crs"])
    image = ngi["dir"] / "frames" / f"{FRAMES[0]}_RGB.tif"
    with pytest.raises(InputError, match=f"look measured on {said}.*measure them on this file or"):
        compare_models(image, path, models=["affine", "dlt", "collinearity"], counts=(12,), trials=1,
                       camera=ngi["camera"], table=tmp_path / "t.csv")
    assert not (tmp_path / "t.csv").exists()
    if case == "x0.5":  # the command line: one line naming the fix, nothing written
        result = CliRunner().invoke(main, ["compare-models", str(image), str(path), "--camera", ngi["camera"],
                                           "--models", "affine,collinearity", "--counts", "12", "--trials", "1",
                                           "--table", str(tmp_path / "t.csv")])
        assert_one_line_error(result, "rescale them (col/row ÷ 0.5)")
        assert not (tmp_path / "t.csv").exists()


@pytest.mark.parametrize("case", ["right image", "crop with an offset"])
def test_compare_models_fits_the_right_image_and_a_crop(ngi, tmp_path, case):
    """No false refusal: the frame's own GCPs on the frame, and the frame's GCPs moved into a crop with an offset
    (its camera's principal point where the frame's falls; the GCPs outside the crop skipped)."""
    from fotogeo import compare_models
    ground, pixel = ngi["sets"][FRAMES[0]]
    image, camera = ngi["dir"] / "frames" / f"{FRAMES[0]}_RGB.tif", ngi["camera"]
    if case != "right image":
        image, pixel = _crop(image, tmp_path / "crop.tif"), pixel - OFFSET
        camera = FrameCamera(120.0, (46.08, 82.944), CROP, principal_point=(W / 2 - OFFSET[0], H / 2 - OFFSET[1]))
    path = _layer(tmp_path / "g.gpkg", ground, pixel, ngi["crs"])
    rows = compare_models(image, path, models=["dlt", "collinearity"], counts=(6,), trials=1, camera=camera)
    coll = [r for r in rows if r["model"] == "collinearity" and r.get("check_rms_xy_px") is not None]
    assert coll and all(r["check_rms_xy_px"] < 3.0 for r in coll), rows


# -- rpc-bias, the affine correction --------------------------------------------------------------------------------
@pytest.mark.data
@pytest.mark.parametrize("case", ["x0.5", "x0.25", "turned", "right image", "crop with an offset"])
def test_rpc_bias_affine_tells_a_copy_from_the_right_image_and_a_crop(data_dir, tmp_path, case):
    """The affinity a0 + a1·col + a2·row absorbs a copy's scale or turn exactly; the vendor RPC's shift does not, so
    the one check (the shift's fit) refuses the copies for ``--method affine`` too, and fits the right GCPs and the
    grid nodes of a product around the crop (the crop 250 px in from its corner: most nodes outside)."""
    from fotogeo import rpc_bias
    from test_rpc_bias_roundtrip import _gcps
    v = data_dir / "rpc" / "ventoux"
    for f in ("left_image.tif", "left_image.geom"):
        shutil.copy(v / f, tmp_path)
    read = {"x0.5": lambda p: p * 0.5, "x0.25": lambda p: p * 0.25,
            "turned": lambda p: np.column_stack([500 - p[:, 1], p[:, 0]])}.get(case)
    offset = case == "crop with an offset"
    rows = _gcps(v, tmp_path / "g.gpkg", bias=np.add((2.3, -1.7), 250 if offset else 0), within=1000 if offset else 500,
                 read=(lambda p: p - 250) if offset else read)
    run = dict(image=tmp_path / "left_image.tif", gcps=tmp_path / "g.gpkg", output=tmp_path / "o.tif",
               method="affine")
    if read is None:
        rep = rpc_bias(**run)
        assert rep["control"]["after"]["rms_xy"] < 0.05 and (len(rep["skipped"]) > len(rows) / 2) == offset
        return
    with pytest.raises(InputError, match=f"look measured on {COPIES[case][1].split(' turned')[0]}"):
        rpc_bias(**run)
    assert not (tmp_path / "o.tif").exists()


# -- triangulate --gcps: each frame's measurements ------------------------------------------------------------------
def _block_control(ngi, tmp_path, read_first=lambda p: p):
    """The two NGI frames' GCPs in one file (frame field), those of the first read by ``read_first``; the block's
    control as triangulate reads it (:func:`fotogeo.tools.triangulate.inputs.read_block_control`)."""
    from fotogeo.tools.triangulate.inputs import read_block_control, read_camera
    parts = []
    for k, name in enumerate(FRAMES):
        ground, pixel = ngi["sets"][name]
        parts.append(gpd.read_file(_layer(tmp_path / f"{k}.gpkg", ground, read_first(pixel) if k == 0 else pixel,
                                          ngi["crs"], f"{name}_RGB", "AB"[k])))
    path = tmp_path / "block.gpkg"
    gpd.GeoDataFrame(np.concatenate([p.values for p in parts]), columns=parts[0].columns, geometry="geometry",
                     crs=ngi["crs"]).to_file(path, driver="GPKG")
    cam, dist = read_camera(ngi["camera"])
    return read_block_control(path, None, None, cam, [f"{n}_RGB" for n in FRAMES], None, dist)


@pytest.mark.parametrize("case", list(COPIES))
def test_triangulate_refuses_a_frame_whose_gcps_were_read_on_a_copy(ngi, tmp_path, case):
    read, said = COPIES[case]
    with pytest.raises(InputError, match=rf"frame {FRAMES[0]}_RGB: the GCP pixels look measured on {said}"):
        _block_control(ngi, tmp_path, read)


def test_triangulate_reads_the_right_frames_control(ngi, tmp_path):
    gcp, _, _ = _block_control(ngi, tmp_path)
    assert len(gcp.name) == 80 and sorted(set(gcp.frame)) == [f"{n}_RGB" for n in FRAMES]


def test_triangulate_command_refuses_the_copy_in_one_line_before_any_work(ngi, tmp_path):
    """``fotogeo triangulate --gcps``: one line naming the file, the frame, the copy and the fix; nothing written."""
    try:
        _block_control(ngi, tmp_path, lambda p: p * 0.5)
    except InputError:
        pass  # the file is written; the refusal is the command's to give
    frames = [str(ngi["dir"] / "frames" / f"{n}_RGB.tif") for n in FRAMES]
    result = CliRunner().invoke(main, ["triangulate", *frames, "--camera", ngi["camera"], "--eo",
                                       str(ngi["dir"] / "exterior_orientation.txt"), "--gcps",
                                       str(tmp_path / "block.gpkg"), "-o", str(tmp_path / "out"), "-q"])
    assert_one_line_error(result, f"frame {FRAMES[0]}_RGB: the GCP pixels look measured on a copy about 0.5x")
    assert "rescale them (col/row ÷ 0.5)" in result.output
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_flat_crop_is_refused_saying_it_cannot_be_told_from_a_copy_and_what_to_give(data_dir, tmp_path):
    """Over flat terrain a crop and a copy fit alike: the refusal says exactly that, and what to give instead — the
    image the GCPs were measured on, or each GCP's own height where the ground has relief (not one constant)."""
    from fotogeo.tools.orient.tool import orient
    from test_orient import NAME
    frame = load_ngi_frame(data_dir / "ngi", NAME)
    rng = np.random.default_rng(1)
    ground = frame.pixel_to_world_at(rng.uniform([5, 5], [W - 5, H - 5], (40, 2)), frame.eo.centre[2] - 3000.0)
    pixel = frame.world_to_pixel(ground) + rng.normal(0, 0.3, (40, 2))
    crop = FrameCamera(120.0, (46.08, 82.944), (W // 2, H // 2), principal_point=(W / 2, H / 2))
    path = _layer(tmp_path / "g.gpkg", ground, pixel, read_dem(data_dir / "ngi" / "dem.tif").crs.to_wkt())
    with pytest.raises(InputError, match=r"a crop of a flat scene cannot be told from a copy: give the image the GCPs "
                                         r"were measured on \(the full frame\), or each GCP's own height \(a z field "
                                         r"or a DEM, not one constant height\) where the ground has relief; if they "
                                         r"were measured on a copy, rescale them"):
        orient(None, path, model="collinearity", camera=crop)


def test_triangulate_keeps_the_span_rule_for_a_frame_beside_a_confirmed_crop(ngi, tmp_path):
    """The span rule (most GCPs outside, spanning more than the image: another image's) is turned off per frame, only
    for the frame whose fit confirms a crop. Frames 0182 and 0184 as top-left crops half the frame's size (the crop's
    camera): 0182's GCPs are its whole frame's (a crop, fitted), 0184's are its frame's positions given to other
    ground points (GCPs of another image). Before, one frame confirmed as a crop turned the rule off for the block:
    0184's few inside were kept, exit 0."""
    from fotogeo.tools.triangulate.inputs import read_block_control
    crop = FrameCamera(120.0, (46.08, 82.944), (W // 2, H // 2), principal_point=(W / 2, H / 2))
    parts = []
    for k, name in enumerate(FRAMES):
        ground, pixel = ngi["sets"][name]
        pixel = pixel if k == 0 else pixel[np.random.default_rng(3).permutation(len(pixel))]
        parts.append(gpd.read_file(_layer(tmp_path / f"{k}.gpkg", ground, pixel, ngi["crs"], f"{name}_RGB", "AB"[k])))
    path = tmp_path / "block.gpkg"
    gpd.GeoDataFrame(np.concatenate([p.values for p in parts]), columns=parts[0].columns, geometry="geometry",
                     crs=ngi["crs"]).to_file(path, driver="GPKG")
    names = [f"{n}_RGB" for n in FRAMES]
    with pytest.raises(InputError, match=r"lie outside the image .* their pixels span .*the col/row were likely "
                                         r"measured on a copy of another size"):
        read_block_control(path, None, None, crop, names, None, None)
    first = tmp_path / "first.gpkg"  # the crop's frame alone is fitted: its GCPs outside skipped
    parts[0].to_file(first, driver="GPKG")
    gcp, _, _ = read_block_control(first, None, None, crop, names, None, None)
    assert 0 < len(gcp.name) < 20 and set(gcp.frame) == {names[0]}
