"""The pair choice of ``fotogeo dsm`` tests what rectification can do (issue 30): the rectified image of a strip
pair grows like 1/sin² of the epipole's distance outside the image, so a pair 16° outside (past the forward rule's
5° margin) rectifies a 3648 x 2432 DJI frame into 9302 x 12055 pixels, beyond :data:`.MAX_RECTIFIED_PIXELS`;
int23 kept it and its ``rectify`` error aborted the whole run. A pair :func:`.rectify` refuses is now left out with
its reason (in the choice, and again when it is set up), naming the ``--resolution`` that fits.
"""
from __future__ import annotations

import numpy as np
import pytest

from fotogeo.errors import ModelError
from fotogeo.stereo.pairs import PairChoice
from fotogeo.stereo.rectify import MAX_RECTIFIED_PIXELS, rectified_extent, rectify
from fotogeo.tools.dsm import plan, tool
from rendered_converging import GROUND
from test_dsm_strip_pairs import _views

BIG = (3648, 2432)


def test_the_choice_keeps_only_pairs_that_rectify_at_the_runs_resolution(tmp_path):
    ims, views = _views(tmp_path, seed=1, size=BIG)
    out = tool._choose(ims, views, [im.name for im in ims], GROUND, None)
    kept = [p for p in out if p.kept]
    assert kept
    for p in kept:  # int23: DJI pairs of 2 x 9302 x 12055 pixels kept, rectify refused them
        rectify(views[p.i], views[p.j], 1.0)
    big = [p for p in out if "rectified pair would have" in p.reason]
    assert big and all("--resolution" in p.reason for p in big)
    # a coarser --resolution rectifies them on a coarser grid: fewer pairs left out for their size
    coarse = tool._choose(ims, views, [im.name for im in ims], GROUND, None, resolution=1.0)
    assert sum("rectified pair would have" in p.reason for p in coarse) < len(big)


def test_a_pair_rectify_refuses_is_left_out_naming_the_resolution_that_fits(tmp_path):
    ims, views = _views(tmp_path, seed=32, size=BIG)
    sizes = {}
    for i in range(len(views)):
        for j in range(i + 1, len(views)):
            try:
                w, h = rectified_extent(views[i], views[j])[-1]
            except ModelError:
                continue
            sizes[(i, j)] = 2 * w * h
    (i, j), n = max(sizes.items(), key=lambda kv: kv[1])
    assert n > MAX_RECTIFIED_PIXELS
    with pytest.raises(ModelError):
        rectify(views[i], views[j], 1.0)
    p, gsd2 = PairChoice(i, j, 1.0, 0.2, 5.0, 0.0), 0.05  # the resolution at scale 1 (map units)
    # set up on its own (int23: the ModelError went up and aborted the run)
    rp, drange, _, why, _, _ = tool._pair_setup(p, views, None, 0.0, 1.0, None, 1.0, {}, ims, gsd2)
    assert rp is None and drange is None and "would have" in why, why
    fit = float(why.split("--resolution ")[1].split()[0])
    assert fit > gsd2
    rp = rectify(views[i], views[j], gsd2 / fit)  # the resolution named fits, a tenth finer does not
    assert 2 * rp.size[0] * rp.size[1] <= MAX_RECTIFIED_PIXELS
    assert plan.size_reason(views[i], views[j], gsd2 / (0.9 * fit), gsd2)


def test_pairs_that_share_no_epipolar_line_are_left_out_in_the_choice(tmp_path):
    # the gimbal 33° below the horizon: the forward rule admits strip pairs that rectify refuses at any size
    ims, views = _views(tmp_path, seed=5, grid=(57.0, 18.0), size=(1368, 912))
    strip = [PairChoice(i, j, 1.0, 0.2, 5.0, 0.0, extra={"distance": 100.0}) for i in range(len(ims))
             for j in range(i + 1, len(ims)) if ims[i].name[4] == ims[j].name[4]]
    refused = []
    for p in strip:
        if plan.forward_reason(p, views):
            continue
        try:
            rectify(views[p.i], views[p.j], 1.0)
        except ModelError:
            refused.append(p)
            assert plan.rectify_reason(p, views), (p.i, p.j)
        else:
            assert not plan.rectify_reason(p, views), (p.i, p.j)
    assert refused
