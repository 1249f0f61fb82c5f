"""register's refusal of an unreferenced target it cannot pre-align named one fix, ``gdal_translate -a_ullr``: a
north-up box, which does not start the windows at a rotated target's place. It names the three-corner georeference
(``gdal_edit.py -a_ulurll``) for a rotated one too, and that route registers the contrast-inverted Landsat chip
rotated 40° and scaled 1.2 (its corners given 3 reference pixels off) where the north-up box around it is refused."""
from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import rasterio
from affine import Affine

from fotogeo.errors import MatchingError
from fotogeo.pixels import pixel_to_map
from rotated_pairs import apply, make_case
from test_refusals_name_what_was_given import unreferenced_target_refusal


def _georeferenced(tgt, path, crs, ul, ur, ll):
    """A copy of ``tgt`` georeferenced by three corners, as ``gdal_edit.py -a_srs CRS -a_ulurll`` sets it."""
    shutil.copy(tgt, path)
    with rasterio.open(path, "r+") as ds:
        w, h = ds.width, ds.height
        ds.crs = crs
        ds.transform = Affine((ur[0] - ul[0]) / w, (ll[0] - ul[0]) / h, ul[0], (ur[1] - ul[1]) / w,
                              (ll[1] - ul[1]) / h, ul[1])
    return path, w, h


def test_the_hint_names_a_georeference_that_holds_a_rotated_target(data_dir, tmp_path, monkeypatch):
    said = unreferenced_target_refusal(monkeypatch)
    assert "\n" not in said and "-a_ullr ULX ULY LRX LRY if it is north-up" in said, said
    assert "rotated, gdal_edit.py -a_srs CRS -a_ulurll ULX ULY URX URY LLX LLY on a copy" in said, said
    monkeypatch.undo()
    from fotogeo.tools.register.tool import register
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref, tgt, H, check = make_case(data_dir, "landsat_r40_s1.2_inverted", tmp_path)
    with rasterio.open(ref) as ds:
        t, crs = ds.transform, ds.crs
    with rasterio.open(tgt) as ds:
        w, h = ds.width, ds.height
    corners = pixel_to_map(t, apply(H, np.array([[0, 0], [w, 0], [0, h], [w, h]], float)))
    off = corners[:3] + np.random.default_rng(0).normal(0, 3 * abs(t.a), (3, 2))  # approximately: ~3 px off
    rotated = _georeferenced(tgt, tmp_path / "rotated.tif", crs, *off)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = register(ref, rotated, tmp_path / "out.tif", overwrite=True, seed=0)
    err = np.hypot(*(r.model.forward(check) - pixel_to_map(t, apply(H, check))).T) / abs(t.a)
    assert np.sqrt(np.mean(err ** 2)) < 0.3
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    box = _georeferenced(tgt, tmp_path / "box.tif", crs, (lo[0], hi[1]), (hi[0], hi[1]), (lo[0], lo[1]))[0]
    with pytest.raises(MatchingError, match="reliable windows"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        register(ref, box, tmp_path / "out_box.tif", overwrite=True, seed=0)
