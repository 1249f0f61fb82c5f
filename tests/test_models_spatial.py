"""Orientation models from GCPs: affine-height, bilinear, DLT, polynomials, RFM, collinearity."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from affine import Affine

from fotogeo.geometry.camera import ExteriorOrientation, FrameCamera, OrientedFrame
from fotogeo.io.camera import load_ngi_frame
from fotogeo.geometry.dem import Dem
from fotogeo.io.raster import read_dem
from fotogeo.errors import InputError, ModelError
from fotogeo.orientation.simulation import make_gcps
from fotogeo.models import DLT, MODELS, Collinearity, IllPosedWarning, get_model, model_from_dict, ransac
from fotogeo.pixels import pixel_centres
from height_sources import CountingDem

CAM = FrameCamera(120.0, (92.16, 165.888), (640, 1152))
FRAME = OrientedFrame(CAM, ExteriorOrientation(500.0, -300.0, 5000.0, 1.5, -2.0, -179.0))
NEW = ["affine-height", "bilinear", "dlt", "poly1", "poly2", "poly3", "poly3d-1", "poly3d-2", "poly3d-3",
       "rfm", "rfm-common", "rfm-poly", "rfm-i2g", "rfm-common-i2g", "rfm-poly-i2g", "collinearity"]


def synthetic_dem():
    t = Affine(25.0, 0.0, -5000.0, 0.0, -25.0, 5000.0)
    x, y = pixel_centres(400, 400)
    X, Y = t.a * x + t.c, t.e * y + t.f
    return Dem(300 + 250 * np.sin(X / 900.0) * np.cos(Y / 700.0) + 0.02 * X, t)


@pytest.fixture(scope="module")
def pinhole_points():
    """Exact ground/pixel pairs of a pinhole frame over synthetic relief (60 points)."""
    g = make_gcps(FRAME, synthetic_dem(), 40, 20, "homogeneous", noise=0.0, seed=7)
    return g


def test_registry_and_class_attributes():
    for name in NEW:
        assert name in MODELS, name
    assert get_model("dlt") is DLT and DLT.n_params == 11 and DLT.min_points == 6 and DLT.src_dims == 3
    assert (MODELS["affine-height"].n_params, MODELS["bilinear"].n_params) == (8, 8)
    assert [MODELS[f"poly{k}"].n_params for k in (1, 2, 3)] == [6, 12, 20]
    assert [MODELS[f"poly3d-{k}"].n_params for k in (1, 2, 3)] == [8, 20, 40]
    assert [MODELS[n].n_params for n in ("rfm", "rfm-common", "rfm-poly")] == [78, 59, 40]
    assert MODELS["rfm-i2g"].direction == "image-to-ground" and MODELS["rfm"].direction == "ground-to-image"
    assert MODELS["bilinear"].src_dims == 2 and MODELS["poly3"].src_dims == 2


@pytest.mark.parametrize("name", ["dlt", "rfm", "rfm-common"])
def test_rational_models_are_exact_for_a_pinhole_camera(pinhole_points, name):
    g = pinhole_points
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = MODELS[name].estimate(g.gcp_ground, g.gcp_pixel)
    assert np.abs(m.forward(g.check_ground) - g.check_pixel).max() < 1e-3
    assert m.residuals(g.gcp_ground, g.gcp_pixel).max() < 1e-3


def test_collinearity_recovers_exterior_orientation(pinhole_points):
    g = pinhole_points
    m = Collinearity.estimate(g.gcp_ground, g.gcp_pixel, camera=CAM)
    eo = m.frame.eo
    assert np.allclose(eo.centre, FRAME.eo.centre, atol=1e-4)
    assert np.allclose([eo.omega, eo.phi, eo.kappa], [1.5, -2.0, -179.0], atol=1e-7)
    assert m.info["init"] == "dlt" and m.info["sigma0"] < 1e-6
    # few points: the start comes from solvePnP
    m4 = Collinearity.estimate(g.gcp_ground[:5], g.gcp_pixel[:5], camera=CAM)
    assert m4.info["init"] == "pnp" and np.allclose(m4.frame.eo.centre, FRAME.eo.centre, atol=1e-3)
    # inverse: exact ray intersection
    P = m.inverse(g.check_pixel, heights=synthetic_dem())
    assert np.abs(P - g.check_ground).max() < 1e-3
    with pytest.raises(InputError, match="interior orientation"):
        Collinearity.estimate(g.gcp_ground, g.gcp_pixel)



def _oblique_over_flat_ground(seed):
    """``(rng, camera, true frame, ground points, pixels)``: a frame 30° off nadir 80 m above ground of ±0.5 m relief,
    its pixels 1 px off."""
    rng = np.random.default_rng(seed)
    cam = FrameCamera(520.0, (640.0, 480.0), (640, 480), (321.5, 238.0))
    truth = OrientedFrame(cam, ExteriorOrientation(0.0, 0.0, 380.0, 0.8, -30.0, -88.0))
    xy = truth.pixel_to_world_at(rng.uniform([0, 0], [640, 480], (220, 2)), 300.0)[:, :2]
    xyz = np.column_stack([xy, 300.0 + 0.5 * np.sin(xy[:, 0] / 40.0) * np.cos(xy[:, 1] / 55.0)])
    px = truth.world_to_pixel(xyz) + rng.normal(0, 1.0, (len(xyz), 2))
    return rng, cam, truth, xyz, px


@pytest.mark.parametrize("seed", range(4))
def test_collinearity_resection_of_an_oblique_frame_over_nearly_flat_ground(seed):
    """A frame 30° off nadir 80 m above ground of ±0.5 m relief, its points 0.2 m off in X, Y, Z (a reference
    at twice the frames' GSD) and 1 px off in the image: the DLT's start is far off (its 11 parameters are
    poorly determined without relief) and the Gauss-Newton from it put points behind the camera on main
    (seeds 0-3: 4 of 4); SQPnP starts it within reach."""
    rng, cam, truth, xyz, px = _oblique_over_flat_ground(seed)
    m = Collinearity.estimate(xyz + rng.normal(0, 0.2, xyz.shape), px, camera=cam)
    assert np.linalg.norm(m.frame.eo.centre - truth.eo.centre) < 0.5 and m.info["sigma0"] < 2.0, m.info


@pytest.mark.parametrize("seed", range(4))
def test_the_resection_is_damped_from_a_start_far_off(seed, monkeypatch):
    """The frame above started from the DLT alone (SQPnP switched off): its start is far off (120 px) and the
    undamped Gauss-Newton put points behind the camera on main (10 seeds of 10); Levenberg-Marquardt takes only
    steps that lower the error with every point in front, and converges (8 of 10; the other two DLT starts have
    points behind the camera and are refused as before)."""
    def no_pnp(*_):
        raise ModelError("SQPnP switched off")
    monkeypatch.setattr(Collinearity, "_pnp", staticmethod(no_pnp))
    rng, cam, truth, xyz, px = _oblique_over_flat_ground(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = Collinearity.estimate(xyz + rng.normal(0, 0.2, xyz.shape), px, camera=cam)
    assert m.info["init"] == "dlt"
    assert np.linalg.norm(m.frame.eo.centre - truth.eo.centre) < 0.5 and m.info["sigma0"] < 2.0, m.info


@pytest.mark.parametrize("name,degree", [("poly1", 1), ("poly2", 2), ("poly3", 3)])
def test_2d_polynomials_reproduce_their_own_degree(name, degree, rng):
    src = rng.uniform(-1000, 1000, (40, 2)) + [3e5, 4e6]
    u = (src - [3e5, 4e6]) / 1000
    dst = np.column_stack([100 + 50 * u[:, 0] + 3 * u[:, 1] + (degree >= 2) * 2 * u[:, 0] * u[:, 1]
                           + (degree >= 3) * u[:, 1] ** 3, 200 - 40 * u[:, 1] + (degree >= 2) * u[:, 0] ** 2])
    m = MODELS[name].estimate(src, dst)
    assert m.residuals(src, dst).max() < 1e-8
    assert np.allclose(m.inverse(m.forward(src[:5])), src[:5], atol=1e-6)
    if degree > 1:  # a lower degree cannot
        assert MODELS[f"poly{degree - 1}"].estimate(src, dst).residuals(src, dst).max() > 0.1


def test_bilinear_and_affine_height_reproduce_their_own_form(rng):
    src = rng.uniform(0, 1000, (20, 3))
    dst = np.column_stack([5 + 0.5 * src[:, 0] - 0.2 * src[:, 1] + 1e-4 * src[:, 0] * src[:, 1], 7 + 0.3 * src[:, 1]])
    assert MODELS["bilinear"].estimate(src[:, :2], dst).residuals(src[:, :2], dst).max() < 1e-8
    dst3 = np.column_stack([5 + 0.5 * src[:, 0] + 0.1 * src[:, 2], 7 + 0.3 * src[:, 1] - 0.2 * src[:, 2]])
    m = MODELS["affine-height"].estimate(src, dst3)
    assert m.residuals(src, dst3).max() < 1e-8
    # inverse of a 3-D model at known heights, and the error when the height is missing
    assert np.allclose(m.inverse(dst3, src[:, 2])[:, :2], src[:, :2], atol=1e-6)
    with pytest.raises(InputError, match="needs the height"):
        m.inverse(dst3)


@pytest.mark.parametrize("name", NEW[:-1])
def test_too_few_points_names_the_minimum(name, rng):
    cls = MODELS[name]
    k = cls.min_points - 1
    with pytest.raises(ModelError, match=f"at least {cls.min_points} points"):
        cls.estimate(rng.uniform(0, 1, (k, cls.src_dims)), rng.uniform(0, 1, (k, 2)))


def test_flat_terrain_is_reported(rng):
    xy = rng.uniform(-2000, 2000, (40, 2))
    flat = np.column_stack([xy, np.zeros(40)])
    px = FRAME.world_to_pixel(flat + [500, -300, 0])
    with pytest.raises(ModelError, match="coplanar"):
        DLT.estimate(flat, px)
    nearly = flat + np.column_stack([np.zeros((40, 2)), rng.uniform(-1, 1, 40)])  # ±1 m over 4 km
    for name in ("affine-height", "dlt", "rfm"):
        with pytest.warns(IllPosedWarning, match="flat terrain"):
            m = MODELS[name].estimate(nearly, px)
        assert m.info["ill_posed"]


def test_rfm_info_reports_regularisation_and_conditioning(pinhole_points):
    g = pinhole_points
    noisy = g.gcp_pixel + np.random.default_rng(1).normal(0, 0.3, g.gcp_pixel.shape)
    with pytest.warns(IllPosedWarning, match="few points"):  # 40 points, 78 parameters
        m = MODELS["rfm"].estimate(g.gcp_ground, noisy)
    info = m.info
    assert {"lambda", "lambda_rel", "dof", "cond", "rank", "iterations", "min_denominator"} <= set(info)
    assert info["cond"][0] > 1e4 and info["dof"][0] < 78 and info["coverage"] > 0.5
    assert 0.0 < info["min_denominator"] <= 1.0


def test_serialisation_round_trip(pinhole_points):
    g = pinhole_points
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        for name in ("dlt", "rfm", "rfm-poly", "poly3d-2", "affine-height"):
            m = MODELS[name].estimate(g.gcp_ground, g.gcp_pixel)
            m2 = model_from_dict(m.to_dict())
            assert np.allclose(m2.forward(g.check_ground), m.forward(g.check_ground), atol=1e-9), name
    c = Collinearity.estimate(g.gcp_ground, g.gcp_pixel, camera=CAM)
    assert np.allclose(model_from_dict(c.to_dict()).forward(g.check_ground), c.forward(g.check_ground))


def test_image_to_ground_rfm_and_inverse(pinhole_points):
    g = pinhole_points
    src = np.column_stack([g.gcp_pixel, g.gcp_ground[:, 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = MODELS["rfm-i2g"].estimate(src, g.gcp_ground[:, :2])
        fwd = MODELS["rfm"].estimate(g.gcp_ground, g.gcp_pixel)
    XY = m.forward(np.column_stack([g.check_pixel, g.check_ground[:, 2]]))
    assert np.abs(XY - g.check_ground[:, :2]).max() < 0.05  # metres (~0.01 px)
    # the inverse of the ground -> image RFM on a DEM gives the ground point
    assert np.abs(fwd.inverse(g.check_pixel, heights=synthetic_dem()) - g.check_ground).max() < 0.05


def test_dlt_serves_the_one_ransac(pinhole_points):
    g = pinhole_points
    px = g.gcp_pixel.copy()
    px[:6] += 40.0  # six blunders
    res = ransac(DLT, g.gcp_ground, px, threshold=1.0, rng=3)
    assert not res.inliers[:6].any() and res.inliers[6:].all()
    res = ransac(Collinearity, g.gcp_ground, px, threshold=1.0, rng=3, fit_options={"camera": CAM})
    assert not res.inliers[:6].any() and res.inliers[6:].all()
    assert np.allclose(res.model.frame.eo.centre, FRAME.eo.centre, atol=1e-3)


# -- the NGI frame: accuracy targets ------------------------------------------------------------

def _check_rms(frame, dem, names, spread, trials=20):
    out = {n: [] for n in names}
    for seed in range(trials):
        g = make_gcps(frame, dem, 40, 20, spread, noise=0.3, seed=seed)
        for n in names:
            cls = MODELS[n]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", IllPosedWarning)
                m = cls.estimate(g.gcp_ground, g.gcp_pixel, **cls.options_from(camera=frame.camera))
            out[n].append(m.forward(g.check_ground) - g.check_pixel)
    return {n: np.sqrt(np.mean(np.concatenate(v) ** 2, axis=0)) for n, v in out.items()}


@pytest.mark.data
@pytest.mark.slow
def test_ngi_homogeneous_targets(data_dir):
    """40 GCPs + 20 check points, 0.3 px noise, 20 seeded trials: check RMS x/y (px)."""
    ngi = data_dir / "ngi"
    rms = _check_rms(load_ngi_frame(ngi, "3324c_2015_1004_05_0182"), read_dem(ngi / "dem.tif"),
                     ["rfm", "dlt", "collinearity", "affine-height"], "homogeneous")
    assert (rms["rfm"] <= 0.15).all(), rms["rfm"]
    assert (rms["dlt"] <= 0.2).all() and (rms["collinearity"] <= 0.15).all()
    assert (rms["affine-height"] > 2.0).all()  # relief: an affine model cannot fit a frame camera


@pytest.mark.data
@pytest.mark.slow
def test_ngi_clustered_rfm_stays_at_the_dlt_level(data_dir):
    """Clustered GCPs, check points everywhere: the regularised RFM extrapolates like the DLT,
    not like an unregularised cubic (poly3d-3 is tens of pixels off)."""
    ngi = data_dir / "ngi"
    rms = _check_rms(load_ngi_frame(ngi, "3324c_2015_1004_05_0182"), read_dem(ngi / "dem.tif"),
                     ["rfm", "dlt", "collinearity", "poly3d-3"], "clustered")
    assert (rms["rfm"] <= 1.1 * rms["dlt"] + 0.05).all(), (rms["rfm"], rms["dlt"])
    assert (rms["rfm"] <= 2.0).all() and (rms["collinearity"] <= 0.5).all()
    assert (rms["poly3d-3"] > 10 * rms["rfm"]).all()


def test_clustered_points_are_reported():
    g = make_gcps(FRAME, synthetic_dem(), 40, 0, "clustered", noise=0.0, seed=2)
    with pytest.warns(IllPosedWarning, match="clustered"):
        m = MODELS["poly3d-2"].estimate(g.gcp_ground, g.gcp_pixel)
    assert m.info["coverage"] < 0.5
    h = make_gcps(FRAME, synthetic_dem(), 40, 0, "homogeneous", noise=0.0, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IllPosedWarning)
        assert MODELS["poly3d-2"].estimate(h.gcp_ground, h.gcp_pixel).info["coverage"] >= 0.9


@pytest.mark.parametrize("name", ["dlt", "rfm"])
def test_dem_intersection_iterates_only_points_that_have_not_converged(pinhole_points, name):
    """Each point stops at the step where its height changed by less than tol_z and keeps that step's answer:
    later steps sample fewer points, and a point's answer does not depend on the other points inverted with it."""
    g = pinhole_points
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        m = MODELS[name].estimate(g.gcp_ground, g.gcp_pixel)
    px = np.vstack([g.check_pixel, g.gcp_pixel])
    dem = CountingDem(synthetic_dem())
    together = m.inverse(px, heights=dem)
    counts = dem.sampled
    assert counts[0] == len(px) and all(a >= b for a, b in zip(counts, counts[1:])) and counts[-1] < len(px)
    alone = np.vstack([m.inverse(p[None], heights=synthetic_dem()) for p in px])
    assert np.abs(together - alone).max() < 1e-9
    assert np.abs(together - np.vstack([g.check_ground, g.gcp_ground])).max() < 0.05
    # the answers are on the terrain to tol_z and project back onto the pixels
    assert np.abs(together[:, 2] - synthetic_dem().heights(together[:, :2])).max() < 1e-3
    assert np.abs(m.forward(together) - px).max() < 1e-6


def _gcps_along_a_line(offset_m):
    """8 GCPs along a 3 km line, ``offset_m`` across it, seen by FRAME with 0.5 px noise."""
    rng = np.random.default_rng(0)
    t = np.linspace(-1500.0, 1500.0, 8)
    xyz = np.column_stack([500 + t, -300 + 0.3 * t + offset_m * rng.standard_normal(8), 100 + 0.01 * t])
    return xyz, FRAME.world_to_pixel(xyz) + rng.normal(0, 0.5, (8, 2))


def test_a_resection_on_nearly_collinear_gcps_reads_its_attitude_undetermined():
    """Points on a line leave the rotation about it free: the plain inverse of JᵀJ gave a finite σ of any size
    (ω 1e6° with numpy's default OpenBLAS kernel, NaN with another, 1e-9 m off the line); the bundle's rule
    (variance inflation above UNDETERMINED_INFLATION) reads ω and φ undetermined, NaN, whatever the BLAS. The same
    points 100 m off the line determine every unknown: all σ finite."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        line = Collinearity.estimate(*_gcps_along_a_line(1e-9), camera=CAM)
        spread = Collinearity.estimate(*_gcps_along_a_line(100.0), camera=CAM)
    assert np.isnan(line.info["std"][3:5]).all(), line.info["std"]
    assert np.isfinite(spread.info["std"]).all(), spread.info["std"]
