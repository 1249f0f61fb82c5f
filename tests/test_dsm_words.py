"""The DSM's user-facing words (issue 30): a pair's reason never reads a value rounded into its limit, the CRS hint
names only a choice that works for the inputs, a refused run still writes its report, meaningless flag
combinations are refused, fotogeo's earlier QGIS style is recognised, and the outputs' errors carry their parts."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from click.testing import CliRunner

from fotogeo.cli import main
from fotogeo.stereo.pairs import Limits, choose_pairs

SQUARE = np.array([[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]], float)


def _pair(dx: float, view_deg: float = 0.0, **given):
    """The choice of two 600 m square footprints ``dx`` metres apart, 1000 m below the cameras; the second looks
    ``view_deg`` degrees off nadir."""
    centres = [np.array([0, 0, 1000.0]), np.array([dx, 0, 1000.0])]
    t = np.radians(view_deg)
    axes = [np.array([0, 0, -1.0]), np.array([np.sin(t), 0, -np.cos(t)])]
    return choose_pairs(centres, axes, [SQUARE + [c[0], c[1], 0] for c in centres], Limits(), **given)[0]


@pytest.mark.parametrize("dx, view, given, words", [
    (482.4, 0.0, None, "overlap 19.6 % below 20 %"),  # was "overlap 20 % below 20 %"
    (81.6, 0.0, None, "base-to-height ratio 0.0798 across"),  # was "0.080 ... below 0.08"
    (400.0, 45.3, None, "the views differ by 45.3 degrees (above 45)"),  # was "by 45 degrees (above 45)"
    (400.0, 45.3, [(0, 1)], "kept as given (the views differ by 45.3 degrees, above 45)"),
])
def test_a_pair_reason_never_reads_as_its_limit(dx, view, given, words):
    p = _pair(dx, view, given=given)
    assert words in p.reason, p.reason


def test_a_pair_reason_far_from_its_limit_keeps_its_short_numbers():
    assert "overlap 12 % below 20 %" in _pair(528.0).reason


NGI = Path(os.environ.get("FOTOGEO_DATA", Path(__file__).resolve().parents[2] / "shared" / "data")) / "ngi"
VENTOUX = NGI.parent / "rpc" / "ventoux"
needs_ngi = pytest.mark.skipif(not (NGI / "exterior_orientation.txt").is_file(), reason="../shared/data/ngi absent")


def _frames_run(tmp_path, command: str, *extra) -> str:
    """``fotogeo COMMAND`` of the two ngi frames (camera, orientation lines without a CRS header) and its output."""
    frames = [str(NGI / "frames" / f"3324c_2015_1004_05_{k}_RGB.tif") for k in ("0182", "0184")]
    args = [command, *(frames if command == "dsm" else frames[:1]), "--camera", str(NGI / "interior_orientation.yaml"),
            "--eo", str(NGI / "exterior_orientation.txt"), "-o", str(tmp_path / "out.tif"), *extra]
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0 and not (tmp_path / "out.tif").exists()
    return r.output


@needs_ngi
@pytest.mark.parametrize("command, extra", [("dsm", ()), ("ortho", ("--height", "1500"))])
def test_a_geographic_crs_on_frames_without_a_dem_does_not_suggest_auto(tmp_path, command, extra):
    """``--crs EPSG:4326`` on frames whose orientation lines state no CRS, without a DEM: the hint said ``'auto'``,
    which is refused for want of a map CRS; it names the CRS of the orientation's X, Y (``map_crs``, shared by
    ``dsm`` and ``ortho``)."""
    out = _frames_run(tmp_path, command, "--crs", "EPSG:4326", *extra)
    assert "is geographic" in out and "'auto'" not in out, out
    assert "use a projected CRS (the CRS the X, Y of --eo are in)" in out, out
    assert "no map CRS" in _frames_run(tmp_path, command, "--crs", "auto", *extra)  # what 'auto' would have met


@needs_ngi
def test_a_geographic_crs_with_a_projected_dem_suggests_auto_and_what_it_takes(tmp_path):
    out = _frames_run(tmp_path, "dsm", "--crs", "EPSG:4326", "--dem", str(NGI / "dem.tif"))
    assert "use a projected CRS ('auto': the DEM's CRS (--dem))" in out, out


@pytest.mark.skipif(not (VENTOUX / "left_image.tif").is_file(), reason="../shared/data/rpc/ventoux absent")
@pytest.mark.parametrize("command, extra", [("dsm", ["right_image.tif"]), ("ortho", ["--height", "100"])])
def test_sfm_frame_with_rpc_is_refused_naming_both_flags(tmp_path, command, extra):
    """``--sfm-frame grid`` with ``--rpc`` was silently ignored (``dsm``, ``ortho``): refused, both flags named."""
    extra = [str(VENTOUX / e) if e.endswith(".tif") else e for e in extra]
    r = CliRunner().invoke(main, [command, "--rpc", str(VENTOUX / "left_image.tif"), *extra, "--sfm-frame", "grid",
                                  "-o", str(tmp_path / "o.tif")])
    assert r.exit_code != 0 and "Traceback" not in r.output
    line = r.output.strip().splitlines()[-1]
    assert "--sfm-frame 'grid'" in line and "--rpc" in line and "leave one of them out" in line, r.output


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    from dsm_scenes import make_scene
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


def test_a_refused_run_writes_its_report_with_the_pairs_tried(nadir, tmp_path):
    """Two frames of different strips overlapping by 8 %: refused, and ``--report`` was not written, so the user could
    not see the pairs tried and why. Now: ``status`` refused, the error's line, the pair with its reason; no DSM."""
    images = [str(nadir["images"][0]), str(nadir["images"][5])]
    out, rep = tmp_path / "dsm.tif", tmp_path / "r.json"
    r = CliRunner().invoke(main, ["dsm", *images, "--camera", str(nadir["camera"]), "--eo", str(nadir["eo"]), "--crs",
                                  nadir["crs"], "-o", str(out), "--report", str(rep)])
    assert r.exit_code != 0 and "no stereo pair among the images" in r.output, r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]  # the report alone: no DSM, no style, no temp
    got = json.loads(rep.read_text())
    assert got["status"] == "refused" and got["error"] in r.output and got["crs_rule"] == "given (--crs)"
    assert [p["images"] for p in got["pairs"]] == [["s1_01", "s2_02"]] and got["pairs_kept"] == 0
    assert got["pairs"][0]["reason"].startswith("overlap 8 % below 20 %") and not got["pairs"][0]["kept"]


def test_a_run_refused_by_the_outputs_checks_leaves_an_existing_report_alone(nadir, tmp_path):
    """An existing report without ``--overwrite`` is refused before the run: it is no place to write."""
    rep = tmp_path / "r.json"
    rep.write_text("{}")
    r = CliRunner().invoke(main, ["dsm", *map(str, nadir["images"][:2]), "--camera", str(nadir["camera"]), "--eo", str(nadir["eo"]),
                                  "--crs", nadir["crs"], "-o", str(tmp_path / "dsm.tif"), "--report", str(rep)])
    assert r.exit_code != 0 and "--overwrite" in r.output and rep.read_text() == "{}"


def _earlier_style(lo: float, hi: float) -> str:
    """The style fotogeo wrote before it marked its own (up to 3678a651): today's text without the marker line (the
    template is otherwise unchanged since f56c3090: ``git diff f56c3090 d19d1d58 -- fotogeo/io/qml.py``)."""
    from fotogeo.io.qml import MARKER, dsm_style
    text = dsm_style(lo, hi).replace(MARKER + "\n", "")
    assert "written by fotogeo" not in text and 'type="singlebandpseudocolor" band="1"' in text
    return text


def test_fotogeos_earlier_unmarked_style_is_replaced_like_a_marked_one(nadir, tmp_path):
    """A ``.qml`` an earlier fotogeo wrote beside its DSM (no marker) was taken for the user's: refused as "a style of
    yours" (QGIS kept it, with the old run's range). Recognised by its content, it is fotogeo's output like the DSM:
    an existing output without ``--overwrite``, replaced by the run's marked style with it."""
    from fotogeo.io.qml import MARKER, users_style
    out = tmp_path / "dsm.tif"
    (tmp_path / "dsm.qml").write_text(_earlier_style(101.25, 187.5))
    assert users_style(out) is None
    args = ["dsm", *map(str, nadir["images"][:2]), "--camera", str(nadir["camera"]), "--eo", str(nadir["eo"]),
            "--crs", nadir["crs"], "-o", str(out), "-q"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0 and "--overwrite" in r.output and "a style of yours" not in r.output, r.output
    r = CliRunner().invoke(main, [*args, "--overwrite"])
    assert r.exit_code == 0 and MARKER in (tmp_path / "dsm.qml").read_text(), r.output


@pytest.mark.parametrize("ending", ["\r\n", "\r"])
def test_fotogeos_earlier_style_saved_with_other_line_endings_is_still_fotogeos(tmp_path, ending):
    """The earlier style copied through Windows (CRLF; or old Mac CR) was compared byte for byte, read with
    ``newline=""``, and taken for the user's: refused as "a style of yours". Its line endings are now compared as
    LF; an edited one stays the user's (:func:`test_an_edited_earlier_style_stays_the_users`)."""
    from fotogeo.io.qml import check_style, users_style
    (tmp_path / "dsm.qml").write_bytes(_earlier_style(101.25, 187.5).replace("\n", ending).encode())
    assert users_style(tmp_path / "dsm.tif") is None
    check_style(tmp_path / "dsm.tif", overwrite=False)  # fotogeo's: the outputs' checks decide, not a refusal
    (tmp_path / "dsm.qml").write_bytes(_earlier_style(101.25, 187.5).replace("245,245,245", "240,240,240")
                                       .replace("\n", ending).encode())
    assert users_style(tmp_path / "dsm.tif") == tmp_path / "dsm.qml"


@pytest.mark.parametrize("edit", [("245,245,245", "240,240,240"), ('suffix=" m"', 'suffix=" ft"'),
                                  ("</qgis>\n", "</qgis>\n<!-- mine -->\n")])
def test_an_edited_earlier_style_stays_the_users(tmp_path, edit):
    """The same file edited (a colour, the legend's unit, a comment) is the user's: refused without overwrite."""
    from fotogeo.errors import OutputError
    from fotogeo.io.qml import check_style, users_style
    (tmp_path / "dsm.qml").write_text(_earlier_style(101.25, 187.5).replace(*edit))
    assert users_style(tmp_path / "dsm.tif") == tmp_path / "dsm.qml"
    with pytest.raises(OutputError, match="did not write it"):
        check_style(tmp_path / "dsm.tif", overwrite=False)


def test_no_height_refusal_keeps_image_names_that_hold_a_colon(nadir, tmp_path):
    """The refusal when no cell got a height was one sentence split at its first ": " to put the resolution before
    the cause: images named ``strip: 1_01`` cut it inside the pair's name ("… pair (strip: --resolution … ; or
    1_01-strip: 1_02): the images …"). Its head and cause now travel apart (:class:`~.outputs.NoHeight`)."""
    import shutil

    from fotogeo.errors import InputError
    from fotogeo.tools.dsm import dsm
    eo = tmp_path / "eo.txt"
    lines = [ln for ln in open(nadir["eo"]).read().splitlines() if ln.startswith(("s1_01 ", "s1_02 "))]
    eo.write_text("".join(ln.replace("s1_", "strip: 1_", 1) + "\n" for ln in lines))
    images = []
    for k in ("01", "02"):
        images.append(tmp_path / f"strip: 1_{k}.tif")
        shutil.copy(next(p for p in nadir["images"] if str(p).endswith(f"s1_{k}.tif")), images[-1])
    with pytest.raises(InputError) as e:
        dsm(images, tmp_path / "dsm.tif", camera=nadir["camera"], eo=eo, crs=nadir["crs"], qgis_style=False,
            resolution=round(0.2 * nadir["gsd"], 2))
    assert str(e.value).startswith("no height was matched in any pair (strip: 1_01-strip: 1_02): --resolution "), e.value
    assert "; or the images may be textureless or cloud-covered where they overlap" in str(e.value), e.value


def test_the_style_ramp_ends_at_the_range_itself_and_an_earlier_interpolated_end_is_still_fotogeos(tmp_path):
    """``lo + 1·(hi − lo)`` differs from ``hi`` in its last bit for some ranges (−3.955488362312317 …
    5.589982786178588, a DSM of the rendered block): the ramp's last item must be ``hi`` itself (QGIS clamps the
    top of the range to the ramp), and a style an earlier fotogeo wrote with the interpolated end is still
    recognised as fotogeo's, not a user's."""
    import re
    from fotogeo.io import qml
    lo, hi = -3.955488362312317, 5.589982786178588
    values = [float(v) for v in re.findall(r'<item value="([^"]*)"', qml.dsm_style(lo, hi))]
    assert values[0] == lo and values[-1] == hi
    earlier = qml.dsm_style(lo, hi, exact_ends=False).replace(qml.MARKER + "\n", "", 1)
    assert earlier != qml.dsm_style(lo, hi).replace(qml.MARKER + "\n", "", 1)  # the ends did differ
    assert qml._earlier_fotogeo(earlier)
    assert not qml._earlier_fotogeo(earlier.replace("245,245,245", "245,245,244"))
