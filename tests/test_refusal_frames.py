"""A refusal carries the frames it refuses as data (FotogeoError.frames): a refused triangulation's line names the
pairs of those frames first, whatever other frame names their names contain."""
import pytest

from fotogeo.errors import InputError, ModelError
from fotogeo.tools.triangulate.refusal import reporting_refusal

NAMES = ["IMG_1", "IMG_12", "IMG_2", "IMG_3"]
#: pairs tried: IMG_1's the weakest, IMG_12's strong
MATCHING = {"pairs": [{"pair": [0, 2], "matches": 30, "inliers": 9}, {"pair": [0, 3], "matches": 31, "inliers": 10},
                      {"pair": [2, 3], "matches": 90, "inliers": 70}, {"pair": [1, 2], "matches": 95, "inliers": 80},
                      {"pair": [1, 3], "matches": 99, "inliers": 85}]}


def _refused(tmp_path, exc):
    with pytest.raises(type(exc)) as info:
        with reporting_refusal(tmp_path / "report.json", MATCHING, NAMES, {"frames": NAMES}):
            raise exc
    return info.value


def test_the_refused_frames_pairs_come_first_by_the_error_s_frames_not_its_text(tmp_path):
    err = _refused(tmp_path, ModelError("frame(s) IMG_12: 3 points — add tie points", frames=["IMG_12"]))
    line = str(err)
    pairs = line.split("(matches/epipolar inliers): ")[1]
    assert pairs.startswith("IMG_12–IMG_2 95/80, IMG_12–IMG_3 99/85, IMG_1–IMG_2 30/9"), line
    assert err.frames == ("IMG_12",) and line.endswith(f"every pair in {tmp_path.name}/report.json")
    assert "— add tie points" in line and (tmp_path / "report.json").is_file()


def test_without_frames_the_weakest_pairs_come_first(tmp_path):
    err = _refused(tmp_path, InputError("the block is disconnected — give more frames", option="frames"))
    pairs = str(err).split("(matches/epipolar inliers): ")[1]
    assert pairs.startswith("IMG_1–IMG_2 30/9, IMG_1–IMG_3 31/10, IMG_2–IMG_3 90/70")
    assert err.option == "frames" and err.frames == ()
