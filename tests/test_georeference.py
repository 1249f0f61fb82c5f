"""Heights in the model protocol, the Georeference (pixel <-> map) and the RANSAC validity hook."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from affine import Affine

from fotogeo.errors import InputError, MatchingError, ModelError
from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.geometry.dem import Dem, HeightSource, as_height_source, heights_at
from fotogeo.geometry.georeference import Georeference
from fotogeo.models import DLT, MODELS, Collinearity, IllPosedWarning, Projective, get_model, model_from_dict, ransac
from fotogeo.orientation.simulation import make_gcps
from fotogeo.pixels import outline, pixel_centres
from height_sources import CountingDem

CAM = FrameCamera(120.0, (92.16, 165.888), (640, 1152))
FRAME = OrientedFrame(CAM, ExteriorOrientation(500.0, -300.0, 5000.0, 1.5, -2.0, -179.0))
W, H = CAM.image_size


def relief_dem():
    t = Affine(25.0, 0.0, -5000.0, 0.0, -25.0, 5000.0)
    x, y = pixel_centres(400, 400)
    X, Y = t.a * x + t.c, t.e * y + t.f
    return Dem(300 + 250 * np.sin(X / 900.0) * np.cos(Y / 700.0) + 0.02 * X, t)


@pytest.fixture(scope="module")
def pairs():
    """Exact ground (X, Y, Z) / pixel pairs of a pinhole frame over relief."""
    return make_gcps(FRAME, relief_dem(), 40, 20, "homogeneous", noise=0.0, seed=5)


@pytest.fixture(scope="module")
def pixels():
    """Image pixels spread over the frame, away from its edges."""
    x, y = pixel_centres(8, 12)
    return np.column_stack([x.ravel() * W / 8, y.ravel() * H / 12])


# -- heights= in the model protocol ----------------------------------------------------------------

def test_inverse_takes_a_number_an_array_or_a_dem(pairs, pixels):
    g, dem = pairs, relief_dem()
    m = DLT.estimate(g.gcp_ground, g.gcp_pixel)
    at_300 = m.inverse(pixels, 300.0)
    assert np.allclose(at_300[:, 2], 300.0)
    assert np.abs(m.forward(at_300) - pixels).max() < 1e-6  # the pixel is reproduced at that height
    z = np.linspace(100.0, 500.0, len(pixels))
    per_point = m.inverse(pixels, heights=z)
    assert np.allclose(per_point[:, 2], z) and np.abs(m.forward(per_point) - pixels).max() < 1e-6
    assert np.array_equal(m.inverse(pixels, heights=np.full(len(pixels), 300.0)), at_300)
    on_dem = m.inverse(pixels, heights=dem)  # intersected with the terrain: its Z is the DEM's
    assert np.abs(on_dem[:, 2] - dem.heights(on_dem[:, :2])).max() < 1e-3
    assert np.abs(on_dem - FRAME.pixel_to_world(pixels, dem)).max() < 0.05
    # a callable XY -> heights is a height source too
    assert np.allclose(m.inverse(pixels, heights=dem.heights), on_dem, atol=1e-6)
    with pytest.raises(InputError, match="needs the height"):
        m.inverse(pixels)


def test_collinearity_heights_and_camera_as_a_fit_option(pairs, pixels):
    g, dem = pairs, relief_dem()
    cls = get_model("collinearity")
    with pytest.raises(ModelError, match="interior orientation"):
        cls.options_from(camera=None)
    assert cls.options_from(camera=CAM, other=1) == {"camera": CAM} and DLT.options_from(camera=CAM) == {}
    m = cls.estimate(g.gcp_ground, g.gcp_pixel, **cls.options_from(camera=CAM))
    assert type(m) is Collinearity and type(model_from_dict(m.to_dict())) is Collinearity
    assert np.abs(m.inverse(pixels, 250.0) - FRAME.pixel_to_world_at(pixels, 250.0)).max() < 1e-3
    assert np.abs(m.inverse(pixels, heights=dem) - FRAME.pixel_to_world(pixels, dem)).max() < 1e-3
    with pytest.raises(InputError, match="needs the height"):
        m.inverse(pixels)


@pytest.mark.parametrize("name", ["projective", "affine", "poly2", "bilinear"])
def test_2d_models_ignore_heights(name, rng):
    src = rng.uniform(0, 1000, (30, 2))
    dst = np.column_stack([3e5 + 2 * src[:, 0] + 0.001 * src[:, 0] * src[:, 1], 4e6 - 2 * src[:, 1]])
    m = MODELS[name].estimate(src, dst)
    plain = m.inverse(dst)
    for heights in (123.0, np.full(len(dst), 7.0), relief_dem()):
        assert np.array_equal(m.inverse(dst, heights), plain)
        assert np.array_equal(Georeference(m, heights=heights).map_to_pixel(dst), m.forward(dst))


def test_heights_at_and_the_height_source_protocol():
    dem = relief_dem()
    XY = np.array([[0.0, 0.0], [1000.0, -500.0]])
    assert isinstance(dem, HeightSource) and isinstance(as_height_source(12.0), HeightSource)
    assert not isinstance(12.0, HeightSource) and not isinstance(np.zeros(2), HeightSource)
    assert heights_at(12.0, XY).tolist() == [12.0, 12.0]
    assert heights_at(np.array([1.0, 2.0]), XY).tolist() == [1.0, 2.0]
    assert np.array_equal(heights_at(dem, XY), dem.heights(XY))
    assert np.array_equal(heights_at(as_height_source(dem.heights), XY), dem.heights(XY))
    with pytest.raises(InputError, match="heights"):
        heights_at(None, XY)


# -- Georeference: pixel -> map -> pixel --------------------------------------------------------------

def test_georeference_2d_round_trip_in_both_directions(rng):
    px = rng.uniform(0, 1000, (40, 2))
    XY = _apply(np.array([[0.5, 0.02, 0.0], [-0.01, -0.5, 0.0], [1e-5, 2e-5, 1.0]]), px) + [3e5, 4e6]
    image_to_map = Georeference(Projective.estimate(px, XY), crs="EPSG:32635", direction="image-to-ground")
    map_to_image = Georeference(MODELS["poly1"].estimate(XY, px), crs="EPSG:32635")  # ground -> image fit
    for geo in (image_to_map, map_to_image):
        on_map = geo.pixel_to_map(px)
        assert np.abs(geo.map_to_pixel(on_map) - px).max() < 1e-6
    assert np.abs(image_to_map.pixel_to_map(px) - XY).max() < 1e-6
    assert image_to_map.footprint(1000, 1000, 5).shape == (20, 2)
    assert image_to_map.ground_sample_distance(1000, 1000) == pytest.approx(0.5, rel=0.05)
    with pytest.raises(InputError, match="direction"):
        Georeference(image_to_map.model, direction="sideways")


@pytest.mark.parametrize("name", ["dlt", "collinearity", "rfm-common"])
def test_georeference_3d_round_trip_on_a_dem_and_at_a_height(pairs, pixels, name):
    g, dem = pairs, relief_dem()
    cls = get_model(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = cls.estimate(g.gcp_ground, g.gcp_pixel, **cls.options_from(camera=CAM))
    geo = Georeference(m, heights=dem, crs="EPSG:32635")
    on_map = geo.pixel_to_map(pixels)
    assert np.abs(on_map - FRAME.pixel_to_world(pixels, dem)[:, :2]).max() < 0.1  # the true ground point
    assert np.abs(geo.map_to_pixel(on_map) - pixels).max() < 1e-3
    flat = geo.with_heights(420.0)
    assert np.abs(flat.map_to_pixel(flat.pixel_to_map(pixels)) - pixels).max() < 1e-3
    assert geo.ground_sample_distance(W, H) > 0 and np.isfinite(geo.footprint(W, H)).all()


def test_georeference_image_to_ground_3d_model(pairs, pixels):
    """An RFM fitted image -> ground, src = (col, row, Z): pixel_to_map intersects the DEM."""
    g, dem = pairs, relief_dem()
    src = np.column_stack([g.gcp_pixel, g.gcp_ground[:, 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = MODELS["rfm-common-i2g"].estimate(src, g.gcp_ground[:, :2])
    geo = Georeference(m, heights=dem, direction="image-to-ground")
    on_map = geo.pixel_to_map(pixels)
    assert np.abs(on_map - FRAME.pixel_to_world(pixels, dem)[:, :2]).max() < 0.5
    assert np.abs(geo.map_to_pixel(on_map) - pixels).max() < 0.05
    at_300 = geo.with_heights(300.0)
    assert np.abs(at_300.pixel_to_map(pixels) - FRAME.pixel_to_world_at(pixels, 300.0)[:, :2]).max() < 0.5


def test_image_to_ground_on_a_dem_iterates_only_points_that_have_not_converged(pairs, pixels):
    """Each pixel stops at the step where its height changed by less than tol_z and keeps that step's
    answer: later steps sample fewer points, and a pixel's answer does not depend on the other pixels
    mapped with it (the old loop went on with every pixel until the last one converged)."""
    g, dem = pairs, relief_dem()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = MODELS["rfm-common-i2g"].estimate(np.column_stack([g.gcp_pixel, g.gcp_ground[:, 2]]), g.gcp_ground[:, :2])
    counting = CountingDem(dem)
    together = Georeference(m, heights=counting, direction="image-to-ground").pixel_to_map(pixels)
    counts = counting.sampled
    assert counts[0] == len(pixels) and all(a >= b for a, b in zip(counts, counts[1:])) and counts[-1] < len(pixels)
    geo = Georeference(m, heights=dem, direction="image-to-ground")
    alone = np.vstack([geo.pixel_to_map(p[None]) for p in pixels])
    assert np.abs(together - alone).max() < 1e-9
    assert np.abs(together - FRAME.pixel_to_world(pixels, dem)[:, :2]).max() < 0.5
    # on the terrain to tol_z: the model at the DEM's height there gives the same ground point
    z = dem.heights(together)
    assert np.abs(m.forward(np.column_stack([pixels, z])) - together).max() < 1e-3

# -- RANSAC validity hook -------------------------------------------------------------------------------

def _apply(Hm, xy):
    h = np.column_stack([xy, np.ones(len(xy))]) @ Hm.T
    return h[:, :2] / h[:, 2:]


def test_folds_matrix_horizon_and_generic_jacobian():
    edge = outline(1000, 1000, 9)
    src = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000], [200, 300.0]])
    folding = Projective.estimate(src, _apply(np.array([[1, 0, 0], [0, 1, 0], [-0.002, 0, 1.0]]), src))
    assert folding.folds(edge)  # horizon x = 500 crosses the image
    assert not Projective.estimate(src, src * 2 + 5).folds(edge)
    xy = np.stack(np.meshgrid(np.linspace(-1, 1, 7), np.linspace(-1, 1, 7)), -1).reshape(-1, 2)
    square = MODELS["poly2"].estimate(xy, np.column_stack([xy[:, 0] ** 2, xy[:, 1]]))  # folds at x = 0
    assert square.folds(outline(2, 2, 9) - 1) and not square.folds(outline(0.8, 2, 9) + [0.2, -1])


def test_ransac_rejects_a_folding_sample(rng):
    """60 pairs follow a homography whose horizon crosses the image, 40 an affine map: without the
    hook RANSAC takes the folding homography (largest consensus), with it the affine one."""
    edge = outline(1000, 1000, 65)
    fold_H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-0.002, 0.0, 1.0]])  # horizon at x = 500
    a = np.column_stack([rng.uniform(0, 300, 60), rng.uniform(0, 1000, 60)])
    b = rng.uniform(600, 1000, (40, 2))
    src = np.vstack([a, b])
    dst = np.vstack([_apply(fold_H, a), b * 1.5 + [100.0, -50.0]])
    plain = ransac(Projective, src, dst, 1.0, rng=0)
    assert plain.inliers[:60].all() and plain.model.folds(edge)
    rejected = []

    def unfolded(model):
        ok = not model.folds(edge)
        rejected.append(not ok)
        return ok

    hooked = ransac(Projective, src, dst, 1.0, rng=0, is_valid=unfolded)
    assert any(rejected) and not hooked.model.folds(edge)
    assert hooked.inliers[60:].all() and not hooked.inliers[:60].any()
    with pytest.raises(MatchingError, match="inliers"):  # nothing valid at all
        ransac(Projective, src, dst, 1.0, rng=0, max_trials=50, is_valid=lambda m: False)
