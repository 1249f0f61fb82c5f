"""Automatic control (issue 13): GCPs for a block from reference orthophotos and a DEM.

Real data: the NGI frames 0182/0184 matched to the two orthophoto tiles; the truth is the
professional exterior orientation (tests/ngi_truth.py), through which every GCP must project
back onto its image measurement, and the DEM, which must give every GCP its height.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.errors import InputError, MatchingError
from fotogeo.geometry.camera import OrientedFrame
from fotogeo.io.raster import read_dem
from fotogeo.io.camera import load_camera, read_exterior_orientation
from fotogeo.tools.triangulate.control import automatic_control
from fotogeo.tools.triangulate.match import thin_to_budget
from ngi_truth import FRAMES

NAMES = [f"{name}_RGB" for name, _ in FRAMES]


def perturbed(eo, rng, metres=20.0, degrees=0.5):
    d, a = rng.normal(0, metres, 3), rng.normal(0, degrees, 3)
    return dataclasses.replace(eo, X=eo.X + d[0], Y=eo.Y + d[1], Z=eo.Z + d[2], omega=eo.omega + a[0],
                               phi=eo.phi + a[1], kappa=eo.kappa + a[2])


@pytest.fixture(scope="module")
def ngi_inputs(data_dir):
    ngi = data_dir / "ngi"
    true = read_exterior_orientation(ngi / "exterior_orientation.txt")
    rng = np.random.default_rng(3)
    return {"ngi": ngi, "frames": [ngi / "frames" / f"{n}.tif" for n in NAMES],
            "camera": load_camera(ngi / "interior_orientation.yaml"), "true": [true[n] for n in NAMES],
            "approx": [perturbed(true[n], rng) for n in NAMES], "dem": read_dem(ngi / "dem.tif"),
            "tiles": sorted((ngi / "ortho").glob("ngi_rgb_byte_*.tif"))}


@pytest.fixture(scope="module")
def ngi_control(ngi_inputs):
    i = ngi_inputs
    return automatic_control(i["frames"], NAMES, i["camera"], i["approx"], i["tiles"], i["dem"], i["dem"].crs,
                             per_frame=90)


def test_control_projects_onto_its_measurements_through_the_true_geometry(ngi_inputs, ngi_control):
    g, cam = ngi_control, ngi_inputs["camera"]
    for name, eo in zip(NAMES, ngi_inputs["true"]):
        m = g.frame == name
        assert 60 <= m.sum() <= 120  # the budget: 10 per region, a few more where multi-frame points add
        d = np.hypot(*(OrientedFrame(cam, eo).world_to_pixel(g.ground[m]) - g.pixel[m]).T)
        # 6.3 m frame pixels against a 5 m orthophoto and a 24 m DEM: measured 0.33 / 0.43 px RMSE
        assert np.sqrt(np.mean(d ** 2)) < 0.8 and np.percentile(d, 95) < 1.5, (name, np.percentile(d, [50, 95]))


def test_control_is_spread_and_shared_between_frames(ngi_inputs, ngi_control):
    g, cam = ngi_control, ngi_inputs["camera"]
    w, h = cam.image_size
    for name in NAMES:
        px = g.pixel[g.frame == name]
        regions = {(int(3 * c / w), int(3 * r / h)) for c, r in px}
        assert len(regions) >= 8, (name, regions)  # Gruber's 9 positions, one may fall outside the reference
    names, counts = np.unique(g.name, return_counts=True)
    assert (counts == 2).sum() >= 10  # one GCP, two image measurements, in the 35 % overlap
    for n in names[counts == 2][:5]:
        assert len(np.unique(g.ground[g.name == n], axis=0)) == 1
    for name in NAMES:  # one measurement per GCP and frame, and no feature twice (the tiles overlap)
        m = g.frame == name
        assert len(set(g.name[m])) == m.sum()
        px = g.pixel[m]
        gap = np.hypot(*(px[:, None] - px[None]).transpose(2, 0, 1)) + 1e9 * np.eye(len(px))
        assert gap.min() > 1.0
    Z = ngi_inputs["dem"].heights(g.ground[:, :2])
    # the block CRS is the DEM's here; a feature of both tiles has the mean of two DEM heights
    np.testing.assert_allclose(g.ground[:, 2], Z, atol=0.5)


def test_thinning_prefers_points_seen_in_more_frames():
    point = np.array([0, 1, 1, 2])
    frame = np.array([0, 0, 1, 1])
    region = np.zeros(4, int)
    score = np.array([0.1, 0.5, 0.5, 0.2]) - 1e3 * np.bincount(point)[point]
    assert thin_to_budget(point, frame, region, score, 1).tolist() == [1]  # point 1 fills both frames


def test_frames_outside_every_reference_are_refused(ngi_inputs):
    i = ngi_inputs
    far = [dataclasses.replace(e, X=e.X + 80000.0) for e in i["approx"]]
    with pytest.raises(MatchingError, match="no frame could be matched to the reference") as info:
        automatic_control(i["frames"], NAMES, i["camera"], far, i["tiles"], i["dem"], i["dem"].crs)
    # what was tried, per frame (the fix follows)
    assert f"({len(NAMES)} frame(s) tried, matches: {NAMES[0]} 0" in str(info.value), str(info.value)


def test_a_reference_without_georeference_is_refused(ngi_inputs, tmp_path):
    import warnings

    import rasterio
    i = ngi_inputs
    plain = tmp_path / "plain.tif"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(plain, "w", driver="GTiff", width=64, height=64, count=1, dtype="uint8") as ds:
            ds.write(np.zeros((1, 64, 64), np.uint8))
    with pytest.raises(InputError, match="plain.tif.*no georeference"):
        automatic_control(i["frames"], NAMES, i["camera"], i["approx"], [i["tiles"][0], plain], i["dem"],
                          i["dem"].crs)
