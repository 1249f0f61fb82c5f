"""Refusals in the words of what the caller gave: the options they can set (by flag on the command line, by label in
QGIS), the inputs they gave and no other, what their files lost, and the likely cause of GCPs measured on another
copy of the image."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from pyproj import CRS, Transformer

from fotogeo.errors import FotogeoWarning, InputError, ModelError
from fotogeo.geometry.camera import FrameCamera
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import BundleOptions, adjust_block

CAMERA = FrameCamera(6.0, (4.0, 6.0), (400, 600))


def _block(n_control: int = 0):
    return simulate_block(seed=2, strips=1, frames_per_strip=3, camera=CAMERA, point_spacing=40.0, margin=3.0,
                          blunder_fraction=0.0, n_check=0, n_control=n_control).block


def test_the_datum_refusal_names_the_options_that_give_priors():
    """The bundle's refusal named its own argument (eo_sigma) and carried no option, so the command line left it as
    it was: it names the option that satisfies it (the centres' σ: the datum counts position priors only; the
    angles' σ cannot give it), by its flag, and exits with the usage code."""
    from fotogeo.cli.common import _in_flags
    with pytest.raises(InputError) as err:
        adjust_block(_block(), BundleOptions())
    assert err.value.option == "eo_sigma_position"
    said = _in_flags(err.value)
    assert "priors on the approximate projection centres (--eo-sigma-position, e.g." in said, said


def test_a_run_that_did_not_converge_says_what_the_files_lost_and_names_only_inputs_given():
    """A resized drone set without its XMP: the adjustment did not converge, and the refusal asked to check a camera
    file and an exterior orientation nobody gave, never naming the lost XMP. It now says what the files lost (the
    camera came from them) and asks to check the inputs of this run."""
    from fotogeo.tools.triangulate.tool import _naming_given_inputs, _overlap_advice, _saying_what_was_lost
    block = _block(n_control=4)
    lost = {n: "a copy resized to 1000x750 without XMP" for n in block.frames}
    with pytest.raises(ModelError) as err, _saying_what_was_lost(lost, camera_from_files=True), \
            _naming_given_inputs(_overlap_advice(None, None, None) + ", and the tie points"):
        adjust_block(block, BundleOptions(snooping=False, max_residual_px=1e-12))
    said = str(err.value)
    assert said.startswith(f"{', '.join(block.frames)}: a copy resized to 1000x750 without XMP"), said
    assert "did not converge" in said and "camera read from the images' EXIF/XMP" in said, said
    assert "the camera file" not in said and "approximate exterior orientation" not in said, said
    with pytest.raises(ModelError) as err, _saying_what_was_lost(lost, camera_from_files=False):
        adjust_block(block, BundleOptions(snooping=False, max_residual_px=1e-12))
    assert "resized" not in str(err.value)  # a camera file was given: the files' loss is not the camera's


def test_gcps_measured_on_a_copy_of_another_size_are_refused_a_few_outside_skipped():
    """Pixels measured on a 2x copy: most GCPs fall outside and the rest gave a wrong model with exit 0."""
    from fotogeo.io.gcps import skip_outside
    rng = np.random.default_rng(0)
    pixel = rng.uniform(0, 1, (30, 2)) * (640, 1152)
    ids, roles = [f"g{i}" for i in range(30)], np.array(["control"] * 30)
    with pytest.raises(InputError, match=r"of 30 GCP\(s\) of g.csv lie outside the image \(640x1152 px\): .*about 2x "
                                         r"the image's size; the col/row were likely measured on a copy of another "
                                         r"size .* measure them on this image \(640x1152 px\)"):
        skip_outside(ids, 2 * pixel, roles, 640, 1152, "g.csv", 3)
    few = pixel.copy()
    few[:3] += 700.0  # three typos: skipped as before
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        keep, skipped = skip_outside(ids, few, roles, 640, 1152, "g.csv", 6)
    assert len(skipped) == 3 and keep.sum() == 27
    assert any(issubclass(w.category, FotogeoWarning) and "are skipped" in str(w.message) for w in caught)


@pytest.mark.parametrize("sfm", [False, True])
def test_centres_far_from_the_images_gps_name_crs_and_exit_as_bad_input(sfm):
    """COLMAP's refusal ended 'check its CRS' with exit 1, OpenSfM's named --sfm-frame with exit 2: each names what
    it is read in — COLMAP the CRS (--crs), an OpenSfM file its frame (--sfm-frame; it is not read in a CRS) — and
    exits with the usage code."""
    from fotogeo.cli.common import _in_flags
    from fotogeo.geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
    from fotogeo.io.gps_keys import GpsFix
    from fotogeo.io.sfm_frame import check_gps
    utm = CRS.from_epsg(32633)
    to_map = Transformer.from_crs(4326, utm, always_xy=True)
    lonlat = {"A": (15.0, 47.0), "B": (15.0005, 47.0)}
    shots = {n: ApproxShot(n, "c", (*to_map.transform(*ll), 100.0), None, 26.0) for n, ll in lonlat.items()}
    shots = {n: ApproxShot(n, "c", (s.position[0] + 26.0, *s.position[1:])) for n, s in shots.items()}
    block = ApproximateBlock({"c": ApproxCamera(CAMERA)}, shots, utm)
    gps = {n: GpsFix(*ll, 100.0, 0.05, True) for n, ll in lonlat.items()}
    with pytest.raises(InputError) as err:
        check_gps(block, gps, "orientation file 'x'", "sfm_frame" if sfm else None)
    said = _in_flags(err.value)
    assert ("check the frame it is read in (--sfm-frame)" if sfm else "check the CRS it is read in (--crs)") in said
    assert ("--crs" in said) != sfm, said
    assert _exit_code(err.value) == 2  # the command line's code of a bad input it can name the option of


def _exit_code(error) -> int:
    """The exit code of a command whose tool raises ``error``."""
    import click
    from click.testing import CliRunner

    from fotogeo.cli.common import run_tool

    @click.command()
    @run_tool
    def cmd():
        raise error
    return CliRunner().invoke(cmd, []).exit_code


def test_a_dem_missing_the_images_of_a_file_read_in_the_crs_given_names_that_crs():
    """A COLMAP model in zone 33 read with --crs EPSG:32632 was refused as a DEM that does not cover the images,
    without naming --crs: the CRS given is named as the likely cause (not for an OpenSfM file, placed by its
    latitude/longitude, nor when no CRS was given)."""
    from fotogeo.cli.common import _in_flags
    from fotogeo.tools.ortho.inputs import SAME_CRS
    from fotogeo.tools.ortho.tool import _crs_as_cause
    missed = InputError(f"DEM 'dem.tif' does not cover images 'A', 'B': the images' ground lies outside it; "
                        f"{SAME_CRS} (EPSG:32633)")
    with pytest.raises(InputError) as err, _crs_as_cause("EPSG:32632", "sparse/0/images.txt"):
        raise missed
    said = _in_flags(err.value)
    assert said.startswith(str(missed)) and "was read in the CRS given (--crs EPSG:32632)" in said, said
    assert _exit_code(err.value) == 2
    for crs, eo in (("auto", "sparse/0/images.txt"), ("EPSG:32632", "opensfm/reconstruction.json")):
        with pytest.raises(InputError) as err, _crs_as_cause(crs, eo):
            raise missed
        assert err.value is missed


def unreferenced_target_refusal(monkeypatch) -> str:
    """register's refusal of an unreferenced target that neither features nor the pre-alignment place."""
    from types import SimpleNamespace

    from fotogeo.errors import MatchingError
    from fotogeo.options import RegisterOptions
    from fotogeo.tools.register import local

    def no_alignment(*args):
        raise MatchingError("no rotation/scale/offset of the target was found")
    monkeypatch.setattr(local, "pre_align", no_alignment)
    with pytest.raises(MatchingError) as err:
        local.area_tie_points("ref.tif", "tgt.tif", None, SimpleNamespace(georeferenced=False), RegisterOptions(),
                              "RANSAC found only 4 inliers")
    return str(err.value)


def test_register_names_only_what_it_takes_for_an_unreferenced_target(monkeypatch):
    """'or give tie points' named an input the register command has none of."""
    said = unreferenced_target_refusal(monkeypatch)
    assert "tie points" not in said and "georeference the target approximately, e.g. gdal_translate" in said, said


def test_an_exact_fit_says_no_blunder_test_is_possible():
    """GCPs computed from the model: 'σ̂ = 0.00 px … blunders above 0.0 px … found with 80 % probability'."""
    from fotogeo.models import get_model
    from fotogeo.orientation.blunders import detect_blunders
    rng = np.random.default_rng(3)
    ground = rng.uniform(0, 1000, (12, 2))
    pix = ground @ [[0.5, 0.01], [-0.02, 0.49]] + [10.0, 20.0]
    note = detect_blunders(get_model("affine"), ground, np.round(pix, 4)).note()
    assert note.startswith("blunder test: not possible, the fit is exact (σ̂ = ") and "probability" not in note, note
    noisy = detect_blunders(get_model("affine"), ground, pix + rng.normal(0, 0.5, pix.shape)).note()
    assert "probability" in noisy and "exact" not in noisy, noisy


def test_an_exact_fit_flags_no_blunder():
    """Computed GCPs with 0.004 px of noise (σ̂ ≈ 0.003 px): the note said the test was not possible while the next
    line flagged a GCP as a blunder for a 0.013 px residual; an exact fit flags none and leaves none out."""
    from fotogeo.models import get_model
    from fotogeo.orientation.blunders import detect_blunders
    rng = np.random.default_rng(17)  # a draw whose chance false alarm was flagged
    ground = rng.uniform(0, 1000, (30, 2))
    pix = ground @ [[0.5, 0.01], [-0.02, 0.49]] + [10.0, 20.0] + rng.normal(0, 0.004, (30, 2))
    test = detect_blunders(get_model("affine"), ground, pix)
    assert "the fit is exact" in test.note()
    assert not (test.flag == "blunder").any() and not (test.flag == "suspect").any(), list(test.flag)
    assert not test.outside.any()
