"""The real NGI pair (frames 0182/0184, one strip) triangulated with automatic control (issue 13).

Inputs: ``../shared/data/ngi`` — two raw DMC frames (640 x 1152, about 6.3 m on the ground), the
camera, a 24 m DEM, two 5 m orthophoto tiles, and ``exterior_orientation.txt`` from a
professional aerial triangulation (the truth). Per seed:

1. the approximate orientation is the true one perturbed (Gaussian, 20 m per axis, 0.5° per angle),
   or (``--start registration``) each frame's own terrain-aware registration to its orthophoto
   (collinearity with the camera): no orientation given at all;
2. automatic control (:func:`fotogeo.tools.triangulate.control.automatic_control`): each frame
   matched to the orthophoto tiles, DEM heights, robust terrain fit, thinned to 90 per frame;
3. tie points between the frames (:func:`fotogeo.tools.triangulate.match.matched_observations`:
   pyramid level ``--level``, Gruber thinning, LSM with σ);
4. bundle adjustment (:func:`fotogeo.orientation.bundle.adjust_block`): control σ 2.5 m in plan
   (half a 5 m orthophoto pixel, the measured reprojection noise of the automatic control) and
   5 m in height (24 m DEM over steep relief);
5. the adjusted orientations against the truth (projection centre m, angles °), and the dense-grid
   ground accuracy: every 10th frame pixel put on the ground at its true height (ray–DEM
   intersection with the true geometry) through the adjusted orientation, RMSE in m against the
   true ground point — beside the same measure for the approximate orientation and for the
   single-frame terrain-aware registration of the same frame (``fotogeo register --dem``, the model
   ``auto`` and ``collinearity`` with the camera).

Prints a table and writes ``benchmarks/results/triangulate_ngi_bench.json``.

With ``--tool`` the same block also goes through ``fotogeo triangulate --reference ... --dem ...``
(its own tie points and control merging), to show what the command gives.

``--bands CASE`` runs the block on a copy of the data with frames or orthophotos in other band sets
(:data:`BAND_CASES`, the bands of :func:`known_warps.derived_bands` made from their RGB; issue 32): a NIR-only frame
beside an RGB one (its tie pair across band sets, its control a NIR frame against RGB orthophotos), a panchromatic and
a 4-band (NIR, B, G, R) frame, NIR-only orthophotos or 8-band orthophotos against the RGB frames.

    .venv/bin/python benchmarks/triangulate_ngi_bench.py [--seeds 3] [--level 1] [--tool] [--bands CASE]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

os.environ.setdefault("GDAL_PAM_ENABLED", "NO")  # nothing written beside the data read

from fotogeo.io.raster import read_dem
from fotogeo.io.camera import load_camera, read_exterior_orientation

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from known_warps import derived_bands  # noqa: E402
from ngi_triangulation import NAMES, dense_grid, registration_rmse, run_seed  # noqa: E402

#: ``--bands`` cases: the band set of each frame (by name; others RGB) and of the orthophotos
BAND_CASES = {"rgb": {}, "frame-nir": {"frames": {NAMES[1]: "n"}},
              "frames-pan-nbgr": {"frames": {NAMES[0]: "pan", NAMES[1]: "nbgr"}},
              "ortho-nir": {"ortho": "n"}, "ortho-8band": {"ortho": "rgb8"}}


def _banded(src: Path, dst: Path, kind: str) -> None:
    """``src`` (RGB) written as ``dst`` in the bands ``kind`` (``nbgr``: NIR, B, G, R), its nodata kept."""
    import rasterio
    with rasterio.open(src) as ds:
        rgb, profile, nodata = ds.read()[:3].astype(np.float64), ds.profile.copy(), ds.nodata
    bands = derived_bands(rgb, "rgbn")[[3, 2, 1, 0]] if kind == "nbgr" else derived_bands(rgb, kind)
    out = np.clip(np.round(bands), 0 if nodata is None else 1, 255).astype(np.uint8)
    if nodata is not None:
        out[:, (rgb == nodata).all(axis=0)] = nodata
    for key in ("photometric", "compress", "jpeg_quality", "blockxsize", "blockysize", "tiled", "interleave"):
        profile.pop(key, None)
    profile.update(driver="GTiff", count=len(out), dtype="uint8", compress="deflate",
                   photometric="RGB" if kind == "rgb" else "MINISBLACK")  # a 4th band is no alpha
    with rasterio.open(dst, "w", **profile) as ds:
        ds.write(out)


def banded_copy(ngi: Path, case: str, folder: Path) -> Path:
    """The NGI folder with the frames and orthophotos of ``BAND_CASES[case]`` in their band sets (the rest linked)."""
    spec = BAND_CASES[case]
    if not spec:
        return ngi
    out = folder / "ngi"
    for sub in ("frames", "ortho"):
        (out / sub).mkdir(parents=True)
    for f in ngi.iterdir():
        if f.is_file():
            (out / f.name).symlink_to(f)
    for f in sorted((ngi / "frames").glob("*.tif")):
        _banded(f, out / "frames" / f.name, spec.get("frames", {}).get(f.stem, "rgb"))
    for f in sorted((ngi / "ortho").glob("*.tif")):
        _banded(f, out / "ortho" / f.name, spec.get("ortho", "rgb"))
    return out


def add_registration(ngi, rows) -> dict:
    """Dense RMSE of the single-frame terrain-aware registration (independent of the seed)."""
    cam = load_camera(ngi / "interior_orientation.yaml")
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    dem = read_dem(ngi / "dem.tif")
    reg = {}
    for n in NAMES:
        px, truth = dense_grid(cam, true[n], dem)
        reg[n] = {m: registration_rmse(ngi, n, m, px, truth) for m in ("collinearity", "auto")}
    return reg


def print_table(rows, reg):
    print(f"{'seed':>4} {'frame':>5} {'approx pos/ang':>15} {'bundle pos/ang':>16} {'dense approx':>12} "
          f"{'dense bundle':>12} {'register coll/auto':>19}")
    for r in rows:
        for n, f in r["frames"].items():
            a, b, d = f["approx"], f["adjusted"], f["dense_rmse_m"]
            print(f"{r['seed']:>4} {n[-8:-4]:>5} {a['position_m']:7.1f} m {a['angle_deg']:.3f}° "
                  f"{b['position_m']:7.2f} m {b['angle_deg']:.4f}° {d['approx']:10.2f} m {d['bundle']:10.2f} m "
                  f"{reg[n]['collinearity']:8.2f} / {reg[n]['auto']:.2f} m")
            if "tool" in f:
                print(f"{'':>10} through fotogeo triangulate: {f['tool']['position_m']:7.2f} m "
                      f"{f['tool']['angle_deg']:.4f}°, dense {d['tool']:.2f} m ({r['tool']['tie_tracks']} tie tracks)")
        print(f"     σ0 {r['sigma0']:.2f}, image RMS {r['image_rms_px']:.3f} px, {r['control_points']} control points "
              f"({r['control_measurements']} measurements), {r['tie_tracks']} tie tracks, "
              f"{r['blunders']} blunders, {r['control_rejected']} control rejected; "
              f"times {', '.join(f'{k} {v:.1f} s' for k, v in r['times_s'].items())}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "ngi"))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--level", type=int, default=1, help="pyramid level of the tie-point detection")
    ap.add_argument("--start", choices=("perturbed", "registration"), default="perturbed",
                    help="approximate orientation: the truth perturbed (20 m, 0.5°, seeded) or "
                         "single-frame registration")
    ap.add_argument("--tool", action="store_true", help="also run the block through fotogeo triangulate")
    ap.add_argument("--bands", choices=tuple(BAND_CASES), default="rgb", help="frames' and orthophotos' bands")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "triangulate_ngi_bench.json"))
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ngi = banded_copy(Path(a.data), a.bands, Path(tmp))
        rows = [run_seed(ngi, s, a.level, tool=a.tool, start=a.start) for s in range(a.seeds)]
        reg = add_registration(ngi, rows)
    print_table(rows, reg)
    Path(a.out).write_text(json.dumps({"note": "times load-dependent (2 shared cores)", "level": a.level,
                                       "bands": a.bands, "rows": rows, "registration_dense_rmse_m": reg},
                                      indent=1, default=float))


if __name__ == "__main__":
    main()
