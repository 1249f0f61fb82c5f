"""Unreferenced, rotated and scaled two-date chips with known truth, shared by tests/test_coarse_similarity.py and
benchmarks/coarse_register_bench.py.

The reference is a real georeferenced scene (or a crop of it); the target is a square chip of another
date's image under the similarity ``H`` (target pixel -> reference pixel, corner convention: rotation,
scale, the chip centre at ``centre`` (fractions of the reference)), bicubic, Gaussian pre-filtered when
coarser, then given another radiometry: a gamma, a band mix, Gaussian noise and optionally clouds
(bright smooth blobs) and an inverted contrast, written without georeference (no CRS, identity transform). ``s2_pair`` uses the
real second date (the AROSICS pair, co-registered to about a pixel) for the chip.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

#: the s2_pair second date's pixel -> the first date's: its georeference says (544, -449), and the two
#: dates are offset by target = reference + (0.66, -1.85) px more (fotogeo coreg on the unrotated pair,
#: 213 reliable 128² windows, std 0.08 px; benchmarks/coarse_register_bench.py --s2-pair-offset)
S2_PAIR_OFFSET = (544 - 0.66, -449 + 1.85)
#: source name -> (reference file, reference crop (col, row, w, h) or None, chip file, chip file's
#: pixel offset to the reference file's pixels (dcol, drow), nodata of the files)
SOURCES = {
    "landsat": ("landsat_rgb/RGB.byte.tif", None, "landsat_rgb/RGB.byte.tif", (0, 0), 0),
    "s2": ("ngi/sentinel2_b432_byte.tif", (0, 200, 797, 900), "ngi/sentinel2_b432_byte.tif", (0, 0), None),
    "s2_pair": ("s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", (600, 900, 1000, 1000),
                "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", S2_PAIR_OFFSET, 0),
    "s2_pair_full": ("s2_pair/ref_S2A_20160608T153121_T33UUU_sub.jp2", None,
                     "s2_pair/tgt_S2A_20160529T153631_T33UUU_sub.jp2", S2_PAIR_OFFSET, 0),
}


@dataclass(frozen=True)
class Case:
    source: str
    deg: float
    scale: float  # target px in reference px
    size: int  # chip side, target px
    centre: tuple  # chip centre, fractions of the reference (crop)
    gamma: float = 1.0
    mix: float = 0.0  # share of the next band mixed into each band
    noise: float = 2.0  # grey levels (of 255)
    clouds: float = 0.0  # fraction of the chip under clouds
    invert: bool = False  # contrast inverted (a band whose vegetation turns from dark to bright)
    mirror: bool = False  # the chip flipped left-right (a scan read from the wrong side): no similarity fits it


#: name -> case; TUNE were used to choose the method's constants, HELD_OUT were not
TUNE = {
    "landsat_r25_s1.1": Case("landsat", 25, 1.1, 300, (0.45, 0.5), gamma=0.7, mix=0.3, noise=3),
    "s2_r40_s0.9": Case("s2", 40, 0.9, 360, (0.5, 0.45), gamma=1.4, mix=0.2, noise=2),
    "s2pair_r-140_s0.9": Case("s2_pair", -140, 0.9, 360, (0.4, 0.55), gamma=1.2, noise=0, clouds=0.1),
}
HELD_OUT = {
    "landsat_r10_s0.8_clouds": Case("landsat", 10, 0.8, 320, (0.6, 0.4), gamma=1.3, mix=0.4, noise=4, clouds=0.15),
    "landsat_r120_s1.25": Case("landsat", 120, 1.25, 260, (0.4, 0.6), gamma=0.6, mix=0.2, noise=3),
    "s2_r-70_s1.15_clouds": Case("s2", -70, 1.15, 300, (0.45, 0.55), gamma=0.8, mix=0.3, noise=3, clouds=0.2),
    "s2_r200_s0.85": Case("s2", 200, 0.85, 400, (0.55, 0.5), gamma=1.2, mix=0.4, noise=2),
    "s2pair_r25_s1.1": Case("s2_pair", 25, 1.1, 400, (0.5, 0.5), noise=0),
    "landsat_r40_s1.2_inverted": Case("landsat", 40, 1.2, 280, (0.55, 0.55), gamma=0.9, mix=0.2, noise=3,
                                      invert=True),
    "s2_r150_s0.95_inverted": Case("s2", 150, 0.95, 340, (0.4, 0.4), gamma=1.1, mix=0.3, noise=2, clouds=0.1,
                                   invert=True),
    "s2pair_r75_s1.2_clouds": Case("s2_pair", 75, 1.2, 380, (0.6, 0.4), gamma=0.8, noise=1, clouds=0.15),
}
#: a new user's chips (issue 32's sweep, benchmarks/coarse_register_bench.py --users): rotations to ±170°, scales
#: 0.7-1.4, chips of 200-2000 px, and mirrored chips, which must be refused
USERS = {
    "s2pair_r170_s1.0": Case("s2_pair", 170, 1.0, 400, (0.5, 0.5), noise=1),
    "s2pair_r-170_s0.7": Case("s2_pair", -170, 0.7, 500, (0.5, 0.5), noise=1),
    "s2pair_r-150_s0.75": Case("s2_pair", -150, 0.75, 450, (0.5, 0.5), noise=1),
    "s2pair_r100_s0.7": Case("s2_pair", 100, 0.7, 450, (0.5, 0.5), noise=1),
    "s2pair_r-30_s0.8": Case("s2_pair", -30, 0.8, 450, (0.5, 0.5), noise=1),
    "landsat_r-95_s1.4": Case("landsat", -95, 1.4, 300, (0.5, 0.5), gamma=0.9, noise=2),
    "s2_r-170_s1.3": Case("s2", -170, 1.3, 300, (0.5, 0.5), gamma=1.1, mix=0.2, noise=2),
    "s2pair_r60_s1.0_200px": Case("s2_pair", 60, 1.0, 200, (0.45, 0.5), noise=1),
    "s2pairfull_r90_s1.3_200px": Case("s2_pair_full", 90, 1.3, 200, (0.4, 0.6), noise=1),
    "s2pairfull_r30_s1.0_1500px": Case("s2_pair_full", 30, 1.0, 1500, (0.5, 0.5), noise=1),
    "s2pairfull_r-170_s0.7_2000px": Case("s2_pair_full", -170, 0.7, 2000, (0.5, 0.5), noise=1),
    "landsat_r30_mirrored": Case("landsat", 30, 1.0, 300, (0.5, 0.5), noise=2, mirror=True),
    "s2pair_r0_mirrored": Case("s2_pair", 0, 1.0, 400, (0.5, 0.5), noise=1, mirror=True),
    "s2_r-60_s1.1_mirrored": Case("s2", -60, 1.1, 320, (0.5, 0.5), noise=2, mirror=True),
}
#: cases of the tests only (no benchmark sweep chose or measured a constant on them)
TESTS = {
    "s2pair_r45_s0.75": Case("s2_pair", 45, 0.75, 420, (0.55, 0.45), noise=1),
    "s2pair_r-100_s0.8": Case("s2_pair", -100, 0.8, 400, (0.45, 0.55), noise=1),
    "s2pair_r-120_s1.0_200px": Case("s2_pair", -120, 1.0, 200, (0.55, 0.45), noise=1),
    "s2pair_r135_s0.7": Case("s2_pair", 135, 0.7, 480, (0.5, 0.5), noise=1),
}
CASES = {**TUNE, **HELD_OUT, **USERS, **TESTS}


def similarity(deg: float, scale: float, size: int, ref_xy, mirror: bool = False) -> np.ndarray:
    """H: target px -> reference px, the chip centre on ``ref_xy``; ``mirror``: the chip's columns reversed first."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    A = scale * np.array([[c, -s], [s, c]]) @ np.diag([-1.0 if mirror else 1.0, 1.0])
    t = np.asarray(ref_xy, float) - A @ np.array([size / 2, size / 2])
    return np.vstack([np.hstack([A, t[:, None]]), [0, 0, 1]])


def _read(path: Path, crop=None):
    import rasterio
    from rasterio.windows import Window
    with rasterio.open(path) as ds:
        win = Window(*crop) if crop else None
        return ds.read(window=win).astype(np.float64), ds.profile.copy(), (ds.window_transform(win) if crop
                                                                            else ds.transform)


def _clouds(size: int, fraction: float, rng) -> np.ndarray:
    """A smooth cloud opacity in [0, 1] covering about ``fraction`` of the chip."""
    if fraction <= 0:
        return np.zeros((size, size))
    noise = cv2.GaussianBlur(rng.normal(size=(size, size)), (0, 0), size / 12)
    thr = np.quantile(noise, 1 - fraction)
    return np.clip((noise - thr) / (0.3 * noise.std()) + 0.5, 0, 1)


def make_case(data: Path, name: str, folder: Path, seed: int = 0):
    """``(reference, target, H, check)``: the pair of case ``name`` written into ``folder``, H (target px ->
    reference px) and the check points (target px inside the reference's valid area, clear of clouds)."""
    import rasterio
    from fotogeo.matching.interpolation import sample
    from fotogeo.pixels import pixel_centres, to_centre
    case = CASES[name]
    rel, crop, chip_rel, offset, nodata = SOURCES[case.source]
    ref_img, profile, ref_transform = _read(Path(data) / rel, crop)
    reference = Path(folder) / f"{name}_reference.tif"
    profile.update(driver="GTiff", width=ref_img.shape[2], height=ref_img.shape[1], transform=ref_transform,
                   nodata=nodata)
    with rasterio.open(reference, "w", **profile) as ds:
        ds.write(ref_img.astype(profile["dtype"]))
    rh, rw = ref_img.shape[1:]
    H = similarity(case.deg, case.scale, case.size, (case.centre[0] * rw, case.centre[1] * rh), case.mirror)
    # the chip is read from its own file: reference px -> chip-file px
    cc, cr = (crop or (0, 0))[:2]
    to_chip = np.array([[1, 0, cc - offset[0]], [0, 1, cr - offset[1]], [0, 0, 1.0]]) @ H
    src_img, _, _ = _read(Path(data) / chip_rel)
    valid_src = np.ones(src_img.shape[1:], bool) if nodata is None else ~(src_img == nodata).all(axis=0)
    x, y = pixel_centres(case.size, case.size)
    p = np.column_stack([x.ravel(), y.ravel(), np.ones(x.size)]) @ to_chip.T
    src = to_centre(p[:, :2])
    sigma = 0.5 * np.sqrt(max(case.scale ** 2 - 1.0, 0.0))
    bands = []
    for b in src_img:
        if sigma > 0:
            b = cv2.GaussianBlur(b, (0, 0), sigma)
        v, _ = sample(b, src[:, 0], src[:, 1], "bicubic")
        bands.append(np.nan_to_num(v).reshape(case.size, case.size))
    vr, _ = sample(valid_src.astype(np.float64), src[:, 0], src[:, 1], "bilinear")
    inside = (np.nan_to_num(vr) > 0.999).reshape(case.size, case.size)
    top = 255.0 if profile["dtype"] == "uint8" else float(np.percentile(src_img[:, valid_src], 99.5))
    rng = np.random.default_rng(seed)
    bands = np.stack(bands) / top
    mixed = (1 - case.mix) * bands + case.mix * np.roll(bands, 1, axis=0)
    out = np.clip(mixed, 0, 1) ** case.gamma
    out = 1 - out if case.invert else out
    cloud = _clouds(case.size, case.clouds, rng)
    out = out * (1 - cloud) + 0.95 * cloud + rng.normal(0, case.noise / 255, out.shape)
    out = np.clip(np.round(out * 254) + 1, 1, 255).astype(np.uint8)
    out[:, ~inside] = 0
    target = Path(folder) / f"{name}_target.tif"
    with rasterio.open(target, "w", driver="GTiff", width=case.size, height=case.size, count=len(out),
                       dtype="uint8", nodata=0) as ds:
        ds.write(out)
    n = 15
    g = (np.arange(n) + 0.5) * case.size / n
    gx, gy = np.meshgrid(g, g)
    check = np.column_stack([gx.ravel(), gy.ravel()])
    keep = inside[check[:, 1].astype(int), check[:, 0].astype(int)] & (cloud[check[:, 1].astype(int),
                                                                              check[:, 0].astype(int)] < 0.5)
    return reference, target, H, check[keep]


def apply(H, xy) -> np.ndarray:
    p = np.column_stack([xy, np.ones(len(xy))]) @ np.asarray(H).T
    return p[:, :2] / p[:, 2:]
