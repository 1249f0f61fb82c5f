"""Pair choice of ``fotogeo dsm`` on a DJI double grid flown at −45° (issue 30): the frames of a line look along it,
their base lies ~45° from the optical axis. A 3:2 frame's border lies 26° from the axis towards the base (42° along
the diagonal), so the epipole lies ~19° above the image and the Fusiello rectification keeps the image whole; the
forward-motion rule measured the base against the half *diagonal* field of view + 5° (47°) and left out every strip
pair: main kept 1 pair of the flight's 66 (DJI_1001/DJI_1002, at 48°). The rule now measures the epipole against
the image border at its own azimuth (:func:`fotogeo.tools.dsm.plan.epipole_margin`); pairs whose epipole lies in the
image or within :data:`~fotogeo.tools.dsm.plan.EPIPOLE_MARGIN` of its border are still left out.
"""
from __future__ import annotations

from collections import Counter

import cv2
import numpy as np

from fotogeo.io.block import write_exterior_orientation, write_interior_orientation
from fotogeo.stereo.pairs import PairChoice
from fotogeo.tools.dsm import frames, plan, tool
from fotogeo.tools.ortho.inputs import image_models
from rendered_converging import CRS, GROUND
from rendered_dji_flight import camera, shots, true_orientation


def _views(tmp_path, seed: int, grid=(45.0, 18.0), size=(171, 114)):
    """The double grid's frames (blank: the pair choice needs their geometry only) with the true orientation."""
    sh = shots("double-grid", np.random.default_rng(seed), grid=grid)
    truth, names = true_orientation(sh), [n for n, *_ in sh]
    cam, eo = tmp_path / "camera.yaml", tmp_path / "eo.txt"
    write_interior_orientation(cam, "dji", camera("p4p", size))
    write_exterior_orientation(eo, names, [truth[n] for n in names])
    paths = [str(tmp_path / f"{n}.JPG") for n in names]
    for p in paths:
        cv2.imwrite(p, np.full((size[1], size[0]), 128, np.uint8))
    ims = image_models(paths, CRS, camera=str(cam), eo=str(eo))
    return ims, [frames.frame_view(im) for im in ims]


def test_a_double_grid_at_minus_45_keeps_its_strip_pairs(tmp_path):
    ims, views = _views(tmp_path, seed=32)
    out = tool._choose(ims, views, [im.name for im in ims], GROUND, None)
    kept = [p for p in out if p.kept]
    partners = Counter([p.i for p in kept] + [p.j for p in kept])
    assert len(kept) >= 8, [(p.i, p.j, p.reason) for p in out if p.view_angle < 10]  # main: 1
    # every frame but one in a pair: DJI_2004's strip partners' rays meet at 4.4° and 3.8° (b⊥/H 0.078, 0.066:
    # below 0.08), its crossing lines' views differ by 60–90°; its ground is DJI_2003/DJI_2005's
    assert sum(partners[k] >= 1 for k in range(len(ims))) >= len(ims) - 1, partners
    for p in kept:  # the strip pairs: views alike, the epipole outside both images by the margin
        b = views[p.j].centre - views[p.i].centre
        assert p.view_angle < 10
        assert min(plan.epipole_margin(views[p.i], b), plan.epipole_margin(views[p.j], b)) >= plan.EPIPOLE_MARGIN


def test_the_epipole_margin_is_measured_at_the_border_of_its_azimuth(tmp_path):
    ims, views = _views(tmp_path, seed=5)
    v = views[0]
    R, (w, h), f = v.rotation, v.size, v.focal
    along = R @ np.array([0.0, -1.0, 1.0])  # 45° up the image: its border 26° away, the diagonal 42°
    assert 14 < plan.epipole_margin(v, along) < 24
    assert plan.epipole_margin(v, -along) == plan.epipole_margin(v, along)  # the base either way
    inside = R @ np.array([0.2 * w / f, 0.1 * h / f, 1.0])  # a pixel inside the frame: negative
    assert plan.epipole_margin(v, inside) < 0
    across = R @ np.array([1.0, 0.0, 0.0])  # a base across the view: far outside
    assert plan.epipole_margin(v, across) > 45


def test_strip_pairs_whose_epipole_lies_in_the_image_stay_left_out(tmp_path):
    # the gimbal 20° below the horizon: the base 20° from the axis, inside the 26° to the border
    ims, views = _views(tmp_path, seed=7, grid=(70.0, 18.0))
    strip = [PairChoice(i, j, 1.0, 0.2, 5.0, 0.0) for i in range(len(ims)) for j in range(i + 1, len(ims))
             if ims[i].name[4] == ims[j].name[4]]
    reasons = [plan.forward_reason(p, views) for p in strip]
    assert len(strip) == 12 and all("the epipole in the image" in r for r in reasons), reasons
