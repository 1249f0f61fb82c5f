"""``fotogeo dsm --resolution`` finer than the images' ground sample distance: one point per pixel matched leaves
most cells empty. The frame run warns when few cells get a height, as the RPC run does, and both name the
resolution as the cause they can see (:func:`fotogeo.tools.dsm.outputs.coverage_cause`); with no height at all the
refusal names it before the texture."""
from __future__ import annotations

import warnings

import pytest

from fotogeo.errors import FotogeoWarning, InputError
from fotogeo.tools.dsm import dsm
from fotogeo.tools.dsm.outputs import coverage_cause

from dsm_scenes import make_scene


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


def _run(sc, out, resolution):
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        rep = dsm(sc["images"][:2], out, camera=sc["camera"], eo=sc["eo"], crs=sc["crs"], resolution=resolution,
                  qgis_style=False)
    return rep, [str(w.message) for w in got if issubclass(w.category, FotogeoWarning)]


def test_a_sparse_dsm_at_a_resolution_finer_than_the_gsd_is_named(nadir, tmp_path):
    """Before: a frame run at about half the GSD came out with a minority of its cells, exit 0, without a word."""
    rep, said = _run(nadir, tmp_path / "dsm.tif", round(0.55 * nadir["gsd"], 2))
    assert rep["completeness"] < 0.5, rep["completeness"]
    low = [s for s in said if "% of the overlap got a height" in s]
    assert low and "finer than the images' ground sample distance" in low[0] and "--resolution" in low[0], said


def test_no_height_at_a_resolution_far_finer_than_the_gsd_names_the_resolution(nadir, tmp_path):
    """Before: "the images may be textureless or cloud-covered" — they are neither."""
    with pytest.raises(InputError, match=r"no height was matched.*--resolution [0-9.]+ is finer than the images' "
                                         r"ground sample distance.*; or the images may be textureless"):
        _run(nadir, tmp_path / "dsm.tif", round(0.2 * nadir["gsd"], 2))


def test_the_cause_named_is_texture_when_the_resolution_is_not_finer_than_the_gsd():
    assert coverage_cause(2.0, 1.0).startswith("textureless")
    assert coverage_cause(2.0, None).startswith("textureless")
    assert "--resolution 0.5 is finer" in coverage_cause(0.5, 1.0) and "--resolution 2 " in coverage_cause(0.5, 1.0)


def test_the_low_coverage_warning_comes_after_the_dsm_is_written(nadir, tmp_path):
    """A caller that turns warnings into errors (``-W error``, an embedding application) lost the finished DSM: the
    warning was raised before the outputs were committed (review 3). Now they are in place when it comes."""
    out = tmp_path / "dsm.tif"
    with warnings.catch_warnings():
        warnings.simplefilter("error", FotogeoWarning)
        with pytest.raises(FotogeoWarning, match="% of the overlap got a height"):
            dsm(nadir["images"][:2], out, camera=nadir["camera"], eo=nadir["eo"], crs=nadir["crs"],
                resolution=round(0.55 * nadir["gsd"], 2), qgis_style=False)
    assert out.is_file()
