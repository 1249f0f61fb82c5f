"""The picker's live preview in a real, headless QGIS (tests/picker_preview_script.py): none below the model's
minimum, the image warped onto the map canvas from the minimum on, redrawn when a GCP is dragged — the picture
around the dragged GCP moves with it —, switched off and on, gone again below the minimum; and the ``enabled``
field added to a GCP layer made elsewhere when one of its points is disabled."""
from __future__ import annotations

import os

import cv2
import numpy as np
import pytest
from test_qgis_picker import run_frame_script

pytestmark = [pytest.mark.qgis]


@pytest.fixture(scope="module")
def previewed(data_dir, tmp_path_factory):
    return run_frame_script("picker_preview_script.py", data_dir, tmp_path_factory.mktemp("preview"))


def test_preview_appears_at_the_models_minimum_and_goes_below_it(previewed):
    s = previewed
    assert not s["two"]["drawn"] and not s["two"]["ok"]  # affine needs 3 control points
    assert s["three"]["drawn"] and s["three"]["ok"] and s["three"]["model"] == "affine"
    assert 0.05 < s["three"]["covered"] < 1.0
    assert not s["below_minimum"]["drawn"]
    assert not s["off"]["drawn"] and s["on_again"]["drawn"]
    assert s["closed"] == {"folder_removed": True, "item_in_scene": False}


@pytest.mark.parametrize("unload", [False, True])
def test_the_preview_folder_is_made_on_first_use_and_never_left_behind(tmp_path, unload):
    """The ``fotogeo-preview-*`` folder was made when the dock was, and left in the temporary folder when the dock
    was never closed (46 of them in /tmp here): now made by the first warp and removed at the interpreter's exit
    or the plugin's unload even when the preview is not closed (run_script checks its temporary folder)."""
    from test_qgis_picker import run_script
    state = run_script("picker_folders_script.py", {"unload": unload}, tmp_path)
    assert state["before_first_warp"] is None and state["after_first_warp"] is True
    assert state.get("after_unload", False) is False


def template_shift(before_png, after_png, screen_xy, canvas_width, half=20, reach=60):
    """``(shift in screen pixels (2,), match score, score where it was)`` of the preview's picture around screen
    point ``screen_xy`` from ``before_png`` to ``after_png`` (normalised cross-correlation of a (2·half + 1)²
    template)."""
    before, after = (cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in (before_png, after_png))
    assert before.shape == after.shape and before.shape[2] == 4
    scale = before.shape[1] / canvas_width  # preview pixels per screen pixel
    x, y = (round(v * scale) for v in screen_xy)
    assert (before[y - half:y + half + 1, x - half:x + half + 1, 3] == 255).all()  # inside the warped image
    template = cv2.cvtColor(before[y - half:y + half + 1, x - half:x + half + 1], cv2.COLOR_BGRA2GRAY)
    area = cv2.cvtColor(after[y - reach:y + reach + 1, x - reach:x + reach + 1], cv2.COLOR_BGRA2GRAY)
    score = cv2.matchTemplate(area, template, cv2.TM_CCOEFF_NORMED)
    _, best, _, (bx, by) = cv2.minMaxLoc(score)
    return np.array([bx - (reach - half), by - (reach - half)]) / scale, best, float(score[reach - half, reach - half])


def test_preview_moves_with_a_dragged_gcp(previewed):
    """Affine on 3 GCPs fits them exactly: the picture around GCP 3 follows GCP 3's drag on the map."""
    s = previewed
    moved, best, _ = template_shift(s["three"]["png"], s["dragged"]["png"], s["gcp3_screen"], s["canvas"][0])
    assert best > 0.8 and moved == pytest.approx(s["drag"], abs=2.0), (best, moved)
    assert s["dragged"]["extent"] == s["three"]["extent"]  # the same canvas: the picture changed, not the frame


def test_disabling_a_point_of_a_layer_without_the_field_adds_it(previewed):
    f = previewed["foreign_layer"]
    assert "enabled" in f["fields"] and f["enabled"] == [False, False] and f["off_fid"]


def test_a_warp_writing_while_the_folder_is_removed_does_not_leave_it(tmp_path, monkeypatch):
    """CI left ``fotogeo-preview-*`` once: a warp still running wrote ``preview.rgba.part`` while the folder was
    being removed, so its last ``rmdir`` found it not empty (``ignore_errors``). Such a write is simulated here: the
    folder is removed again until it is gone."""
    import shutil
    from processing_provider.picker import preview
    folder = tmp_path / "fotogeo-preview-x"
    folder.mkdir()
    (folder / "preview.rgba").write_bytes(b"old")
    real = shutil.rmtree
    calls = []

    def rmtree_with_a_write(path, ignore_errors=False):
        calls.append(path)
        if len(calls) > 1:
            return real(path, ignore_errors=ignore_errors)
        for entry in list(os.scandir(path)):
            os.remove(entry.path)
        (folder / "preview.rgba.part").write_bytes(b"new")  # the worker's write lands after the listing
        try:
            os.rmdir(path)
        except OSError:
            assert ignore_errors  # not empty: rmtree(ignore_errors=True) says nothing

    monkeypatch.setattr(preview.shutil, "rmtree", rmtree_with_a_write)
    preview._FOLDERS.add(str(folder))
    preview.remove_folder(str(folder))
    assert not folder.exists() and str(folder) not in preview._FOLDERS and len(calls) == 2
