"""The registration tool end to end: a known synthetic warp of a real image, and bad input."""
import hashlib
import json

import numpy as np
import pytest
import rasterio

from fotogeo.errors import Cancelled, InputError, MatchingError, ModelError, OutputError, RasterError
from fotogeo.pixels import pixel_centres, pixel_to_map
from fotogeo.tools.register.tool import register
from synthetic_pair import apply_h, make_landsat_pair

DETECTOR = "surf"
@pytest.fixture(scope="module")
def pair(data_dir, tmp_path_factory):
    """Landsat RGB as reference; the target is it under H_TRUE, re-banded and without georeference."""
    ref, tgt, H = make_landsat_pair(data_dir / "landsat_rgb" / "RGB.byte.tif", tmp_path_factory.mktemp("pair"))
    return ref, tgt, H, tgt.parent


def _sha(p):
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.mark.parametrize("refine", ["none", "lsm"])
def test_known_warp_is_recovered(pair, tmp_path, refine):
    ref, tgt, H, _ = pair
    before = (_sha(ref), _sha(tgt))
    out = tmp_path / "out.tif"
    r = register(ref, tgt, out, detector=DETECTOR, seed=1, refine=refine)
    assert (_sha(ref), _sha(tgt)) == before  # inputs untouched
    rep = json.loads((tmp_path / "out.json").read_text())
    assert rep["output_crs"] == "EPSG:32618" and rep["check"]["n"] >= 20
    # tie points of a noisy, re-banded, up-scaled 300 m image scatter by about a pixel ...
    assert rep["check"]["rmse_px"] < 1.5, rep["check"]
    if refine == "lsm":
        assert rep["lsm"]["refined"] > 50
    # dense truth: the fitted model against the true mapping over the whole target
    with rasterio.open(ref) as ds:
        t_ref = ds.transform
    x, y = pixel_centres(64, 60)
    grid = np.column_stack([x.ravel(), y.ravel()]) * 10
    truth = pixel_to_map(t_ref, apply_h(H, grid))
    err = np.hypot(*(r.model.forward(grid) - truth).T)
    # ... while the fitted model is right to a third of a pixel (measured 0.25 px, 0.19 with LSM)
    assert np.sqrt(np.mean(err ** 2)) < 0.35 * t_ref.a
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 32618 and ds.count == 3 and ds.dtypes[0] == "uint8" and ds.nodata == 0
        assert ds.res == pytest.approx((t_ref.a, -t_ref.e), rel=1e-4)  # square pixels of equal area
        assert ds.overviews(1) and ds.profile["tiled"]
        out_img = ds.read(1)
        # the output agrees with the reference's red band re-banded as target band 1 (blue*0.7+30)
        from rasterio.warp import reproject
        ref_on = np.zeros_like(out_img)
        with rasterio.open(ref) as rs:
            reproject(rs.read(3), ref_on, src_transform=rs.transform, src_crs=rs.crs,
                      dst_transform=ds.transform, dst_crs=ds.crs)
    ok = (out_img > 0) & (ref_on > 0)
    assert ok.mean() > 0.3
    assert np.corrcoef(out_img[ok], ref_on[ok])[0, 1] > 0.9
    import geopandas as gpd
    tp = gpd.read_file(tmp_path / "out.gpkg", layer="tie_points")
    ev = gpd.read_file(tmp_path / "out.gpkg", layer="error_vectors")
    assert len(tp) == len(ev) == rep["control"]["n"] + rep["check"]["n"]
    assert set(tp.role) == {"control", "check"} and tp.crs.to_epsg() == 32618
    assert np.allclose(ev.length, ev.exaggeration * np.hypot(ev.dx, ev.dy))  # drawn k times (auto)


def test_options_crs_resolution_resampling(pair, tmp_path):
    ref, tgt, _, _ = pair
    out = tmp_path / "o.tif"
    register(ref, tgt, out, detector=DETECTOR, dst_crs="EPSG:3857", resolution=60.0, resampling="bilinear",
             model="affine")
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 3857 and ds.res == (60.0, 60.0)


def test_bad_inputs_give_clear_errors_and_no_output(pair, tmp_path):
    ref, tgt, _, d = pair
    out = tmp_path / "x.tif"
    with pytest.raises(InputError, match="no georeference"):
        register(tgt, ref, out, detector=DETECTOR)
    with pytest.raises(OutputError, match="is also an input"):
        register(ref, tgt, tgt, detector=DETECTOR)
    with pytest.raises(RasterError, match="does not exist"):
        register(ref, tmp_path / "missing.tif", out)
    bad = tmp_path / "corrupt.tif"
    bad.write_bytes(b"II*\x00" + b"\x00" * 100)
    with pytest.raises(RasterError, match="cannot be read"):
        register(ref, bad, out)
    const = tmp_path / "const.tif"
    with rasterio.open(const, "w", driver="GTiff", width=100, height=100, count=1, dtype="uint8") as ds:
        ds.write(np.full((1, 100, 100), 7, np.uint8))
    with pytest.raises(InputError, match="constant"):
        register(ref, const, out, detector=DETECTOR)
    empty = tmp_path / "empty.tif"
    with rasterio.open(empty, "w", driver="GTiff", width=100, height=100, count=1, dtype="uint8", nodata=0) as ds:
        ds.write(np.zeros((1, 100, 100), np.uint8))
    with pytest.raises(InputError, match="no valid pixels"):
        register(ref, empty, out, detector=DETECTOR)
    noise = tmp_path / "noise.tif"
    with rasterio.open(noise, "w", driver="GTiff", width=300, height=300, count=1, dtype="uint8") as ds:
        ds.write(np.random.default_rng(0).integers(0, 255, (1, 300, 300), dtype=np.uint8))
    with pytest.raises(MatchingError, match="(matches|inliers)"):
        register(ref, noise, out, detector=DETECTOR)
    with pytest.raises((MatchingError, ModelError), match="overlap"):  # real images of different places
        register(ref, ref.parent.parent / "ngi" / "ortho" / "ngi_rgb_byte_1.tif", out, detector=DETECTOR)
    with pytest.raises(InputError, match="resampling"):
        register(ref, tgt, out, resampling="lanczos9")
    assert not out.exists() and not list(tmp_path.glob("x.*")) and not list(tmp_path.glob(".x*"))
    existing = tmp_path / "exists.tif"
    existing.write_bytes(b"keep")
    with pytest.raises(OutputError, match="overwrite"):
        register(ref, tgt, existing, detector=DETECTOR)
    assert existing.read_bytes() == b"keep"


@pytest.mark.parametrize("stop_at", [0.3, 0.8])
def test_cancel_leaves_nothing(pair, tmp_path, stop_at):
    ref, tgt, _, _ = pair
    seen = []

    def progress(f, msg):
        seen.append(f)
        return f < stop_at

    with pytest.raises(Cancelled):
        register(ref, tgt, tmp_path / "c.tif", detector=DETECTOR, progress=progress)
    assert max(seen) >= stop_at and list(tmp_path.iterdir()) == []
