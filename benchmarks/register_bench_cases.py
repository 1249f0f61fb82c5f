"""The pairs of benchmarks/register_bench.py (:func:`build_cases`) and their truth (:class:`Truth`: target pixel ->
true map XY, a dense grid, the share of raw matches within ``CORRECT_TOL_PX`` of it)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from register_bench_common import CORRECT_TOL_PX, DATA, NGI_FRAMES


# ------------------------------------------------------------------------------ inputs
def make_landsat_pair(folder: Path):
    """Landsat RGB under the known warp of tests/synthetic_pair.py; returns (reference, target, H)
    with H: target px -> reference px."""
    from synthetic_pair import make_landsat_pair as make
    return make(DATA / "landsat_rgb" / "RGB.byte.tif", folder)


def build_cases(tmp: Path, quick: bool):
    from fotogeo.tools.demo.tool import make_scene
    ngi = DATA / "ngi"
    cases = []
    for key, (name, ortho) in NGI_FRAMES.items():
        cases.append(dict(name=key, reference=str(ngi / "ortho" / ortho),
                          target=str(ngi / "frames" / f"{name}_RGB.tif"), options={},
                          truth={"kind": "ngi", "frame": name}, otb180=True))
    if not quick:
        cases.append(dict(name="s2_to_ngi", reference=str(ngi / "ortho" / "ngi_rgb_byte_1.tif"),
                          target=str(ngi / "sentinel2_b432_byte.tif"), options={},
                          truth={"kind": "georef", "crs": "EPSG:32735"}))
        s2 = DATA / "s2_pair"
        cases.append(dict(name="s2_pair", reference=str(s2 / "ref_S2A_20160608T153121_T33UUU_sub.jp2"),
                          target=str(s2 / "tgt_S2A_20160529T153631_T33UUU_sub.jp2"),
                          options=dict(reference_nodata=0, target_nodata=0, model="affine"),
                          truth={"kind": "georef", "crs": "EPSG:32633"}))
        ref, tgt, H = make_landsat_pair(tmp)
        cases.append(dict(name="landsat_warp", reference=str(ref), target=str(tgt), options={},
                          truth={"kind": "homography", "H": H.tolist()}))
    scene = make_scene(tmp / "demo", seed=7)
    cases.append(dict(name="demo", reference=str(scene.reference), target=str(scene.target), options={},
                      truth={"kind": "demo", "seed": 7}))
    return cases


# ------------------------------------------------------------------------------ truth
class Truth:
    """target pixel (corner convention) -> true map XY in the output CRS, and a dense grid."""

    def __init__(self, case, tmp: Path):
        self.kind = case["truth"]["kind"]
        t = case["truth"]
        if self.kind == "georef":  # approximate: the target's own georeference (orthoimages)
            from pyproj import CRS
            from fotogeo.pixels import pixel_centres
            from fotogeo.io.raster import open_raster
            info = open_raster(case["target"])
            self.t_tgt, self.tgt_crs, self.crs = info.transform, info.crs, t["crs"]
            self.out_crs = CRS.from_user_input(self.crs)
            x, y = pixel_centres(info.width // 50, info.height // 50)
            self.grid = np.column_stack([x.ravel(), y.ravel()]) * 50
            self.truth = self(self.grid)
        elif self.kind == "ngi":
            from pyproj import CRS
            from fotogeo.io.camera import load_ngi_frame
            from fotogeo.io.raster import read_dem
            from ngi_truth import truth_points  # tests/ngi_truth.py, shared with the tests
            ngi = DATA / "ngi"
            self.dem = read_dem(ngi / "dem.tif")
            self.frame = load_ngi_frame(ngi, t["frame"])
            self.src_crs, self.dst_crs = CRS.from_wkt(self.dem.crs.to_wkt()), CRS.from_epsg(32735)
            self.crs = "EPSG:32735"
            self.grid, xyz = truth_points(ngi, t["frame"], step=10, crs=32735)
            self.truth = xyz[:, :2]
            # a target made from a crop of the frame, scaled: frame px = offset + target px * scale
            self.offset, self.scale = np.asarray(t.get("offset", (0.0, 0.0)), float), float(t.get("scale", 1.0))
            if "scale" in t:
                g = (self.grid - self.offset) / self.scale
                ok = ((g >= 0) & (g <= t["size"])).all(axis=1)
                self.grid, self.truth = g[ok], self.truth[ok]
        elif self.kind == "homography":
            import rasterio
            from fotogeo.pixels import pixel_centres
            self.H = np.array(t["H"])
            with rasterio.open(case["reference"]) as ds:
                self.t_ref, self.crs = ds.transform, ds.crs.to_string()
            x, y = pixel_centres(64, 60)  # as tests/test_register.py
            self.grid = np.column_stack([x.ravel(), y.ravel()]) * 10
            self.truth = self(self.grid)
        elif self.kind == "demo":
            from fotogeo.tools.demo.tool import make_scene
            from fotogeo.pixels import pixel_centres
            self.scene = make_scene(tmp / "demo_truth", seed=t["seed"])
            self.crs = "EPSG:32635"
            x, y = pixel_centres(90, 70)  # as fotogeo.tools.demo.tool.truth_comparison (step 10)
            grid = np.column_stack([x.ravel(), y.ravel()]) * 10
            truth = self(grid)
            ok = np.isfinite(truth).all(axis=1)
            self.grid, self.truth = grid[ok], truth[ok]

    def __call__(self, xy):
        xy = np.asarray(xy, float).reshape(-1, 2)
        if self.kind == "georef":
            from fotogeo.crs import transform_points
            from fotogeo.pixels import pixel_to_map
            return transform_points(self.tgt_crs, self.out_crs, pixel_to_map(self.t_tgt, xy))
        if self.kind == "ngi":
            from fotogeo.crs import transform_points
            g = self.frame.pixel_to_world(self.offset + xy * self.scale, self.dem)[:, :2]
            out = np.full_like(g, np.nan)
            ok = np.isfinite(g).all(axis=1)
            if ok.any():
                out[ok] = transform_points(self.src_crs, self.dst_crs, g[ok])
            return out
        if self.kind == "homography":
            from synthetic_pair import apply_h as _apply
            from fotogeo.pixels import pixel_to_map
            return pixel_to_map(self.t_ref, _apply(self.H, xy))
        return self.scene.frame.pixel_to_world(xy, self.scene.dem)[:, :2]

    def in_crs(self, crs: str) -> "Truth":
        """This truth with its dense grid's true positions in ``crs`` (register writes in the reference's CRS, e.g.
        the NGI orthophotos' transverse Mercator, not the UTM zone the truth is made in); raw matches are still
        judged in :attr:`crs` (:meth:`correct_share`)."""
        import copy
        from pyproj import CRS
        from fotogeo.crs import transform_points
        if CRS.from_user_input(crs) == CRS.from_user_input(self.crs):
            return self
        out = copy.copy(self)
        out.truth = transform_points(CRS.from_user_input(self.crs), CRS.from_user_input(crs), self.truth)
        return out

    def evaluate(self, model, reference, raw=None) -> dict:
        from fotogeo.models import Projective
        rms = lambda e: float(np.sqrt(np.mean(np.asarray(e) ** 2)))  # noqa: E731
        dense = rms(model.residuals(self.grid, self.truth))
        if self.kind == "georef":  # not a truth: only the distance from the target's own georeference
            out = {"georef_rmse_m": dense}
        else:
            best = rms(Projective.estimate(self.grid, self.truth).residuals(self.grid, self.truth))
            out = {"n_grid": int(len(self.grid)), "dense_rmse_m": dense, "best_homography_rmse_m": best}
            if best > 1e-6 * max(1.0, dense):
                out["dense_over_best"] = dense / best
        if raw is not None and len(raw["target_xy"]):
            out.update(self.correct_share(raw, reference))
        return out

    def correct_share(self, raw, reference) -> dict:
        """Raw matches whose reference position lies within CORRECT_TOL_PX of the true position."""
        from pyproj import CRS
        from fotogeo.crs import pixel_size_in, transform_points
        from fotogeo.pixels import pixel_to_map
        from fotogeo.io.raster import open_raster
        ref = open_raster(reference)
        crs = CRS.from_user_input(self.crs)
        px = pixel_size_in(ref.transform, ref.crs, crs, ref.width / 2, ref.height / 2)
        got = transform_points(ref.crs, crs, pixel_to_map(ref.transform, raw["reference_xy"]))
        err = np.hypot(*(self(raw["target_xy"]) - got).T)
        err = np.where(np.isfinite(err), err, np.inf)
        return {"raw_matches": int(len(err)), "raw_correct": int(np.sum(err <= CORRECT_TOL_PX * px)),
                "raw_correct_share": float(np.mean(err <= CORRECT_TOL_PX * px)),
                "raw_correct_against": "target georeference (approximate)" if self.kind == "georef" else "truth"}
