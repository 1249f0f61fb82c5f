"""The picker's table (issue 22) in a real, headless QGIS (tests/picker_table_script.py): sorted by clicks on its
header, numbers as numbers; whatever the order, selection, Delete, undo/redo and a role edit act on the GCP shown
in the row; a refit keeps the sort and the selected GCP; at least ten rows visible in the dock."""
from __future__ import annotations

import pytest
from test_qgis_picker import run_frame_script

pytestmark = [pytest.mark.qgis]


@pytest.fixture(scope="module")
def sorted_table(data_dir, tmp_path_factory):
    return run_frame_script("picker_table_script.py", data_dir, tmp_path_factory.mktemp("table"))


def _numbers(texts):
    return [float(t) for t in texts]


def test_header_click_sorts_ids_as_numbers_and_residuals_descending(sorted_table):
    s = sorted_table
    descending, ascending = s["by_id"]["ids"]
    assert ascending == [str(k) for k in range(1, 11)] and descending == ascending[::-1]  # "2" before "10"
    res = _numbers(s["by_residual"]["res"])
    assert res == sorted(res, reverse=True) and res[0] > res[-1]
    by_fit = sorted(s["by_residual"]["fit"], key=lambda p: -p["residual_px"])
    assert s["by_residual"]["ids"] == [p["id"] for p in by_fit]
    assert s["by_residual"]["ids"][0] == "5"  # the GCP clicked 12 px off on the map


def test_delete_on_the_top_row_deletes_the_largest_residual(sorted_table):
    d = sorted_table["delete"]
    assert d["top"] == [d["largest"]] == ["5"]
    assert d["after"] == [i for i in d["before"] if i != "5"] and "5" not in d["table_after"]
    res = _numbers(d["res_after"])
    assert res == sorted(res, reverse=True)  # the refill after the delete keeps the sort
    # undo adds it back (at the layer's end), redo deletes it again
    assert sorted(d["undone"], key=int) == d["before"] and d["redone"] == d["after"]


def test_a_refit_keeps_the_selected_gcp_not_the_row_number(sorted_table):
    r = sorted_table["refit"]
    assert len(r["chosen"]) == 1 and r["controller"] == r["chosen"][0]
    assert r["ids_after"] != r["ids_before"]  # the projective fit reorders the rows
    res = _numbers(r["res_after"])
    assert res == sorted(res, reverse=True)
    assert r["selected_after"] == r["chosen"] and r["selected_rows"] == [r["ids_after"].index(r["chosen"][0])]


def test_a_role_edit_in_the_sorted_table_changes_that_gcp(sorted_table):
    r = sorted_table["role"]
    assert r["top"] == "5" and r["roles"]["5"] == "check"
    assert all(role == "control" for i, role in r["roles"].items() if i != "5")
    assert all(role == "control" for role in r["undone"].values())


def test_the_image_has_the_larger_share_and_the_table_at_least_six_rows(sorted_table):
    g = sorted_table["geometry"]
    assert g["visible_rows"] >= g["min_rows"] == 6
    assert g["canvas_height"] >= 0.45 * g["dock_height"]  # where the user clicks: the larger share of the split
