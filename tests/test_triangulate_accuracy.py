"""How triangulate states its accuracy and derives its defaults (issue 22): control placed by the images alone
beside the σ-weighted residuals, automatic-control σ from the inputs, a check fraction where control is spare."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fotogeo.io.block import GcpList
from fotogeo.orientation.block_simulation import simulate_block
from fotogeo.orientation.bundle import adjust_block
from fotogeo.orientation.bundle_control import images_only_errors
from fotogeo.tools.triangulate.control import reference_sigmas
from fotogeo.tools.triangulate.inputs import check_fraction_for
from fotogeo.tools.triangulate.outputs import accuracy_lines


def test_images_only_errors_show_what_the_control_sigma_hides():
    """Control of 2-3 cm σ keeps ``adjusted − given`` at millimetres whatever the images say; placed by their
    rays alone the points are off by the images' precision, and one given 1 m off (σ 1 m) shows it."""
    sb = simulate_block(seed=5, blunder_fraction=0.0)
    b = sb.block
    ctrl = np.flatnonzero(b.role == "control")
    xyz, sig = b.point_xyz.copy(), b.point_sigma.copy()
    xyz[ctrl[2], 0] += 1.0
    sig[ctrl[2]] = 1.0
    r = adjust_block(dataclasses.replace(b, point_xyz=xyz, point_sigma=sig))
    errors = images_only_errors(r, dataclasses.replace(b, point_xyz=xyz))
    assert np.isnan(errors[np.setdiff1d(np.arange(len(b.point_ids)), ctrl)]).all()
    assert abs(errors[ctrl[2], 0] + 1.0) < sb.gsd  # the images put it back near where it is
    good = np.delete(ctrl, 2)
    images_rms = np.sqrt(np.mean(errors[good, :2] ** 2))
    weighted_rms = np.sqrt(np.mean((r.point_xyz[good, :2] - xyz[good, :2]) ** 2))
    assert weighted_rms < 0.01 and 5 * weighted_rms < images_rms < 0.5 * sb.gsd
    assert r.stats["control_images"]["n"] == len(ctrl)
    lines = accuracy_lines({"statistics": r.stats})
    assert [line.split(" (")[0] for line in lines] == ["check points", "control points placed by the images alone",
                                                       "control adjusted − given"]
    assert "σ-weighted" in lines[2]


def test_automatic_control_sigma_from_the_orthophoto_and_dem_pixels(data_dir):
    ngi = data_dir / "ngi"
    refs = [ngi / "ortho" / "ngi_rgb_byte_1.tif", ngi / "ortho" / "ngi_rgb_byte_2.tif"]
    crs = "+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84"
    xy, z = reference_sigmas(refs, ngi / "dem.tif", crs)
    assert xy == pytest.approx(2.5, rel=0.01)  # 5 m orthophotos
    assert z == pytest.approx(12.0, rel=0.05)  # 24 m DEM
    assert reference_sigmas(refs, ngi / "dem.tif", crs, 0.3, None)[0] == 0.3
    assert reference_sigmas(None, None, crs, 0.3, 2.0) == (0.3, 2.0)


def _gcps(n_points: int, rays: int, role=None) -> GcpList:
    names = np.repeat([f"g{k}" for k in range(n_points)], rays).astype(object)
    ground = np.zeros((len(names), 3))
    return GcpList("EPSG:32735", names, ground, np.zeros((len(names), 2)), np.array(["a", "b"] * n_points)[:len(names)]
                   if rays == 2 else np.full(len(names), "a", dtype=object), role)


@pytest.mark.parametrize("n, rays, checks, expected", [(12, 2, set(), 0.2), (9, 2, set(), 0.0), (30, 1, set(), 0.0),
                                                       (12, 2, {"g1"}, 0.0)])
def test_check_fraction_where_control_is_spare(n, rays, checks, expected):
    assert check_fraction_for(None, _gcps(n, rays), checks) == expected
    assert check_fraction_for(0.5, _gcps(n, rays), checks) == 0.5


def test_no_automatic_check_fraction_when_the_file_names_check_points():
    g = _gcps(12, 2, np.array(["control"] * 22 + ["check"] * 2, dtype=object))
    assert check_fraction_for(None, g, set()) == 0.0
    assert check_fraction_for(None, None, set()) == 0.0


def test_report_html_reads(tmp_path):
    """report.html: the CRS named in a line with its WKT folded and wrapped, residual panels 360 px high with
    titles that fit, captions (the legend of the red dots) as HTML text that wraps, the accuracy rows labelled."""
    import base64
    import re

    import cv2
    from pyproj import CRS

    from fotogeo.tools.triangulate.outputs import report
    from fotogeo.tools.triangulate.report import write_html
    sb = simulate_block(seed=1, strips=1, frames_per_strip=3)
    r = adjust_block(sb.block)
    wkt = CRS.from_proj4("+proj=tmerc +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84").to_wkt()
    rep = report(r, sb.block, CRS.from_wkt(wkt), {"folder": str(tmp_path)})
    write_html(tmp_path / "report.html", rep, r, sb.block, {"geometry": []})
    text = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "<pre class='wrap'>" in text and "word-break:break-all" in text
    assert re.search(r"<p>CRS [^<]{1,120} <details>", text)
    captions = re.findall(r"<figcaption>(.*?)</figcaption>", text)
    assert len(captions) == 3 and "culled as blunders" in captions[0] and "#dc0000" in captions[0]
    assert "rejected control" in captions[2]
    first = re.search(r"src='data:image/png;base64,([^']+)'", text).group(1)
    panels = cv2.imdecode(np.frombuffer(base64.b64decode(first), np.uint8), cv2.IMREAD_COLOR)
    assert panels.shape[0] >= 360 and panels.shape[1] >= 3 * 200
    assert "control placed by the images alone" in text and "control adjusted − given (σ-weighted)" in text
