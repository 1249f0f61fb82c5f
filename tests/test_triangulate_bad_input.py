"""fotogeo triangulate on bad input: one ``Error:`` line naming the input and the fix, nothing written."""
from __future__ import annotations

import pytest
from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.errors import InputError
from fotogeo.orientation.block_simulation import simulate_block
from test_bad_input import assert_one_line_error
from test_triangulate import CAMERA, write_block


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_block")
    sb = simulate_block(seed=6, strips=2, frames_per_strip=5, camera=CAMERA, point_spacing=50.0, margin=3.0,
                        n_check=8)
    frames, checks = write_block(d, sb)
    lines = (d / "gcp_list.txt").read_text().splitlines()
    gcp = [ln.split() for ln in lines[1:]]
    first = gcp[0][6]
    outside = [lines[0]] + [" ".join(p[:3] + ["5000", "9000"] + p[5:]) if p[6] == first else " ".join(p) for p in gcp]
    (d / "outside.txt").write_text("\n".join(outside) + "\n")
    everywhere = [lines[0]] + [" ".join(p[:3] + ["5000", "9000"] + p[5:]) for p in gcp]
    (d / "all_outside.txt").write_text("\n".join(everywhere) + "\n")
    (d / "elsewhere.txt").write_text("\n".join([lines[0]] + [ln.replace(".JPG", "_x.JPG") for ln in lines[1:]]) + "\n")
    from pyproj import Transformer
    to34 = Transformer.from_crs("EPSG:32635", "EPSG:32634", always_xy=True)
    eo34 = []
    for ln in (d / "eo.txt").read_text().splitlines():
        p = ln.split()
        x, y = to34.transform(float(p[1]), float(p[2]))
        eo34.append(" ".join([p[0], f"{x:.3f}", f"{y:.3f}", *p[3:]]))
    (d / "eo_utm34.txt").write_text("\n".join(eo34) + "\n")
    moved = [lines[0]] + [" ".join([str(float(p[0]) + 5.0), *p[1:]]) if p[6] == first and k == 0 else " ".join(p)
                          for k, p in enumerate(gcp)]
    (d / "moved.txt").write_text("\n".join(moved) + "\n")
    (d / "noz.csv").write_text("id,frame,x,y,col,row\ng1,s1_01.tif,500000,4420000,10,20\n")
    (d / "badrole.csv").write_text("id,frame,x,y,z,col,row,role\ng1,s1_01.tif,500000,4420000,50,10,20,survey\n")
    return d, frames, first


def _args(d, frames, **kw):
    base = {"--camera": d / "camera.yaml", "--eo": d / "eo.txt", "--observations": d / "tie.csv",
            "--gcps": d / "gcp_list.txt", **kw}
    out = d / "out"
    out.mkdir(exist_ok=True)
    return ["triangulate", *map(str, frames), *[str(x) for k, v in base.items() if v is not None for x in (k, v)],
            "-o", str(out), "-q"]


CASES = {
    "all control outside the frames": ({"--gcps": "all_outside.txt"}, "0 control point(s) remain, the block needs 1"),
    "control in no frame of the block": ({"--gcps": "elsewhere.txt"}, "no measurement names a frame of the block"),
    "orientation and control in different CRSs": ({"--eo": "eo_utm34.txt"}, "do not fit together"),
    "one id at two places": ({"--gcps": "moved.txt"}, "have different ground coordinates"),
    "table without heights": ({"--gcps": "noz.csv", "--crs": "EPSG:32635"}, "lacks the field(s) z"),
    "unknown role": ({"--gcps": "badrole.csv", "--crs": "EPSG:32635"}, "role values must be 'control' or 'check'"),
    "neither orientation nor control": ({"--eo": None, "--gcps": None, "--crs": "EPSG:32635"},
                                        "none of the 10 frames carries a GPS position in the EXIF/XMP; give their "
                                        "positions (--geoinfo, or --eo"),
    "check points without control": ({"--gcps": None, "--crs": "EPSG:32635", "--check-points": "p1"},
                                     "names given but no ground control"),
    "geographic map CRS": ({"--crs": "EPSG:4326"}, "map CRS of the block"),
    "reference without DEM": ({"--reference": "camera.yaml"}, "needs the DEM"),
    "check fraction too large": ({"--check-fraction": "0.9"}, "check_fraction 0.9"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_triangulate_bad_input_is_one_line(block, case):
    d, frames, first = block
    given, expected = CASES[case]
    kw = {k: (None if v is None else (v if k in ("--crs", "--check-points", "--check-fraction") else d / v))
          for k, v in given.items()}
    result = CliRunner().invoke(main, _args(d, frames, **kw), terminal_width=200)
    assert_one_line_error(result, expected)
    if case == "all control outside the frames":
        assert f"{first} in " in result.stderr and "lie outside the image (" in result.stderr
    assert not any((d / "out").iterdir())



def _flat_dem(path, d, height_above_cameras: float):
    """A flat DEM over the block at the highest camera's height plus ``height_above_cameras``."""
    import numpy as np
    import rasterio
    eo = np.array([[float(v) for v in ln.split()[1:4]] for ln in (d / "eo.txt").read_text().splitlines()])
    lo, hi = eo[:, :2].min(axis=0) - 3000, eo[:, :2].max(axis=0) + 3000
    with rasterio.open(path, "w", driver="GTiff", width=60, height=60, count=1, dtype="float32", crs="EPSG:32635",
                       transform=rasterio.transform.from_bounds(*lo, *hi, 60, 60)) as ds:
        ds.write(np.full((1, 60, 60), eo[:, 2].max() + height_above_cameras, np.float32))
    return path


def _run_with_dem(block, tmp_path, dem):
    d, frames, _ = block
    out = tmp_path / "out"
    # the frame check's angle σ scales with max(σ0, 1); this small block sits just above its 0.5° limit
    args = [a for a in _args(d, frames, **{"--dem": dem, "--max-angle-sigma": 1.0}) if a != "-q"]  # -q hides warnings
    args[args.index("-o") + 1] = str(out)
    return CliRunner().invoke(main, args + ["--orthorectify"], terminal_width=200), out


def test_a_dem_above_the_cameras_is_refused(block, tmp_path):
    """Issue 24: a DEM 10 km too high stops the run before anything is written."""
    result, out = _run_with_dem(block, tmp_path, _flat_dem(tmp_path / "dem_high.tif", block[0], 10_000.0))
    assert_one_line_error(result, "above the projection centre")
    assert not out.exists() or not any(out.iterdir())


def test_orthophotos_on_heights_never_seen_are_refused_per_frame(block, tmp_path):
    """A DEM just under the cameras, far above every control point: no frame is orthorectified on it, each is
    named in a warning and in the report, and the adjustment's own outputs are kept."""
    import json
    result, out = _run_with_dem(block, tmp_path, _flat_dem(tmp_path / "dem_near.tif", block[0], -20.0))
    assert result.exit_code == 0, result.output
    warned = [line for line in result.stderr.splitlines() if "not orthorectified" in line]
    assert len(warned) == len(block[1]) and all("never saw" in line for line in warned), result.stderr
    report = json.loads((out / "report.json").read_text())
    assert all("never saw" in v["error"] for v in report["orthorectified"].values())
    assert not list(out.glob("*_ortho.tif")) and (out / "exterior_orientation.txt").is_file()


def test_a_point_outside_every_frame_is_skipped_as_orient_skips_it(block):
    """triangulate's control goes through orient's rule (fotogeo.io.gcps.skip_outside): the measurements outside
    their frame are skipped by name with the same warning; on main a point outside every frame refused the block."""
    import warnings
    from fotogeo.io.block import frame_key, read_control
    from fotogeo.io.camera import read_camera_with_distortion
    from fotogeo.tools.triangulate.inputs import _in_frames
    d, frames, first = block
    camera = read_camera_with_distortion(d / "camera.yaml")[0]
    gcp = read_control(d / "outside.txt")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kept = _in_frames(gcp, [frame_key(f) for f in frames], camera, d / "outside.txt")
    w, h = camera.image_size
    text = " ".join(str(c.message) for c in caught)
    assert first not in set(kept.name) and (gcp.name == first).sum() >= 2
    assert f"lie outside the image ({w}x{h} px) and are skipped" in text
    assert text.count(f"{first} in ") == (gcp.name == first).sum(), text  # each measurement named
    # the rest counted as measurements of points (each point is measured in several frames)
    assert f"the other {len(kept.name)} measurements of {len(set(kept.name))} points used" in text, text


def test_the_control_left_is_counted_in_points_not_measurements():
    """A point measured in three frames is one control point: with three needed and it alone left inside its frames,
    the GCPs are refused (on main its three measurements counted as three points and passed)."""
    import numpy as np

    from fotogeo.io.gcps import skip_outside
    ids = ["A in f1", "A in f2", "A in f3", "B in f1", "B in f2", "C in f3"]
    pixel = np.array([[10, 10], [20, 20], [30, 30], [5000, 9000], [5000, 9000], [-4, 50]], float)
    roles = np.array(["control"] * 6)
    with pytest.raises(InputError, match=r"1 control point\(s\) remain \(measured 3 times\), the block needs 3"):
        skip_outside(ids, pixel, roles, 100, 100, "GCP file 'g.txt'", 3, "the block", points=list("AAABBC"))
    keep, skipped = skip_outside(ids[:4], pixel[:4], roles[:4], 100, 100, "g", 1, "the block", points=list("AAAB"))
    assert keep.tolist() == [True, True, True, False] and [s["id"] for s in skipped] == ["B in f1"]
