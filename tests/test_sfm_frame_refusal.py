"""The refusal of an OpenSfM file whose local frame nothing decides: its fix (``sfm_frame``) stays on the one line
however much evidence comes before it, and images that were given are not asked for again. It separated the fix
with "; ", so one_line cut it when three evidence sources were listed ("… or say which with --sfm-frame topocent…")."""
from __future__ import annotations

import sys
from pathlib import Path

from fotogeo.errors import one_line
from fotogeo.io.sfm_frame import refusal

WHERE = "OpenSfM reconstruction '/data/odm_x2/opensfm/reconstruction.json'"
EXIF = ("the camera centres vs the GPS of the exif/<image>.exif beside it (16 image(s), σ 15 m): 0.029 m RMS "
        "horizontally as grid, 2.609 m as topocentric: too close to tell")
SHOTS = ("the camera centres vs the shots' gps_position (topocentric, as OpenSfM writes it) (16 image(s), σ 15 m): "
         "0.029 m RMS horizontally as grid, 2.609 m as topocentric: too close to tell")
IMAGES = ("the camera centres vs the images' own EXIF GPS (2 image(s), σ 5 m): 3.079 m RMS horizontally as grid, "
          "5.638 m as topocentric: too close to tell")


def test_the_fix_survives_the_cut_and_images_given_are_not_asked_for_again():
    text = one_line(str(refusal(WHERE, "; ".join((IMAGES, EXIF, SHOTS)), (4.15, 2.6), gps_given=True)))
    assert text.endswith("— give images with a GPS precise enough to tell them apart (RTK), or say which with "
                         "sfm_frame topocentric (OpenSfM) or grid (ODM)")
    assert "give the images themselves" not in text


def test_without_images_it_asks_for_images_with_gps():
    text = one_line(str(refusal(WHERE, "; ".join((EXIF, SHOTS)), (4.15, 2.6), gps_given=False)))
    assert text.endswith("— give the images with GPS (their EXIF GPS decides), or say which with sfm_frame "
                         "topocentric (OpenSfM) or grid (ODM)")


def test_the_wording_follows_the_callers_flag_not_the_evidence_text():
    """Whether images with GPS were given is the caller's to say: a reason worded otherwise (another source's
    sentence, a translation) does not turn the fix into asking for the same images again, nor the other way."""
    rtk = "— give images with a GPS precise enough to tell them apart (RTK), or say which"
    with_gps = "— give the images with GPS (their EXIF GPS decides), or say which"
    assert rtk in one_line(str(refusal(WHERE, "; ".join((EXIF, SHOTS)), (4.15, 2.6), gps_given=True)))
    assert with_gps in one_line(str(refusal(WHERE, IMAGES, (4.15, 2.6), gps_given=False)))


def test_the_benchmark_counts_a_refusal_by_name_only_with_the_option_whole():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from sfm_projects_bench import by_name
    assert by_name("Error: $W/x.json: … — give images with GPS, or say which with --sfm-frame topocentric or grid")
    assert not by_name("Error: $W/x.json: too close to tell; give the images themselves, or say which …")
    assert not by_name("Error: $W/x.json: too close; give the images, or say which with --sfm-frame topocent…")
    assert not by_name("Error: $W/x.json is not a reconstruction")
