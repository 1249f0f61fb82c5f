"""Area-based matching inside the registration: tie points from windows when feature matching fails,
and ``local``, the displacement field on top of the model (fotogeo.tools.register.local)."""
from __future__ import annotations

import numpy as np
import pyogrio
import pytest
import rasterio
from click.testing import CliRunner

import coreg_scenes as cs
from fotogeo.cli import main
from fotogeo.errors import InputError, MatchingError
from fotogeo.tools.register.tool import register


@pytest.fixture(scope="module")
def seasonal(data_dir, tmp_path_factory):
    """Landsat red against a blurred, inverted, noisy blue band under a rotation, scale and a 1-px ripple
    (tests/coreg_scenes.py): SURF finds 4 inliers among 30 matches."""
    folder = tmp_path_factory.mktemp("seasonal")
    ref_a, tgt_a, E = cs.seasonal_landsat()
    return (cs.write_geotiff(folder / "ref.tif", ref_a, dtype="uint8"),
            cs.write_geotiff(folder / "tgt.tif", tgt_a, dtype="uint8"))


def test_seasonal_pair_registers_through_windows_and_the_local_field_removes_the_ripple(seasonal, tmp_path):
    ref, tgt = seasonal
    with pytest.raises(MatchingError, match="inliers"):  # feature matching alone fails
        register(ref, tgt, tmp_path / "no.tif", area_fallback=False)
    assert not list(tmp_path.iterdir())
    plain = register(ref, tgt, tmp_path / "plain.tif", resampling="cubic")
    assert plain.report["area_based"]["windows"]["reliable"] >= 50
    assert "feature matching failed" in plain.report["summary"][0]
    local = register(ref, tgt, tmp_path / "local.tif", resampling="cubic", local=True, local_grid_spacing=32)
    assert local.report["local"]["windows"]["reliable"] >= 50
    assert (tmp_path / "local_field.tif").is_file()
    assert "local_windows" in {name for name, _ in pyogrio.list_layers(tmp_path / "local.gpkg")}
    before, after = cs.misregistration(ref, tmp_path / "plain.tif"), cs.misregistration(ref, tmp_path / "local.tif")
    # the projective model leaves the ripple (~1 px: median 0.95 px measured); the field takes it out
    # (median 0.07 px measured; nearest-neighbour resampling alone leaves ~0.25 px)
    assert before["median"] > 0.7, before
    assert after["median"] < 0.12 and after["ce90"] < 0.3, (before, after)
    with rasterio.open(tmp_path / "local.tif") as a, rasterio.open(tmp_path / "plain.tif") as b:
        assert (a.crs, a.res, a.dtypes, a.nodata) == (b.crs, b.res, b.dtypes, b.nodata)


def test_field_without_local_and_odd_local_window_are_refused(seasonal, tmp_path):
    ref, tgt = seasonal
    with pytest.raises(InputError, match="--local"):
        register(ref, tgt, tmp_path / "o.tif", field=tmp_path / "f.tif")
    with pytest.raises(InputError, match="local_window must be an even"):
        register(ref, tgt, tmp_path / "o.tif", local=True, local_window=65)
    assert not list(tmp_path.iterdir())


def test_a_target_without_georeference_is_pre_aligned_not_guessed(seasonal, tmp_path):
    """The same target without its georeference: the Fourier–Mellin pre-alignment gives the windows their
    start, and the registration agrees with the georeferenced target's (fotogeo.tools.register.coarse)."""
    ref, tgt = seasonal
    with rasterio.open(tgt) as ds:
        data = ds.read(1)
    raw = tmp_path / "raw.tif"
    with rasterio.open(raw, "w", driver="GTiff", width=data.shape[1], height=data.shape[0], count=1,
                       dtype=data.dtype) as ds:
        ds.write(data, 1)
    geo = register(ref, tgt, tmp_path / "geo.tif")
    r = register(ref, raw, tmp_path / "o.tif")
    assert r.report["area_based"]["pre_alignment"]["confidence_peak_ratio"] >= 3
    with rasterio.open(ref) as ds:
        px = abs(ds.transform.a)
    g = np.stack(np.meshgrid(np.linspace(10, data.shape[1] - 10, 9), np.linspace(10, data.shape[0] - 10, 9)), -1)
    g = g.reshape(-1, 2)
    d = np.hypot(*(r.model.forward(g) - geo.model.forward(g)).T) / px
    assert np.sqrt(np.mean(d ** 2)) < 0.5, d


def test_coreg_command_writes_its_outputs_and_refuses_in_one_line(seasonal, tmp_path):
    ref, tgt = seasonal
    args = ["coreg", str(ref), str(tgt), "--grid-spacing", "32", "-q"]
    r = CliRunner().invoke(main, args + ["-o", str(tmp_path / "c.tif")])
    assert r.exit_code == 0, r.output
    assert "reliable" in r.output and "left by the field" in r.output
    for name in ("c.tif", "c.gpkg", "c_field.tif", "c.json"):
        assert (tmp_path / name).is_file(), name
    r = CliRunner().invoke(main, args + ["--window", "127", "-o", str(tmp_path / "d.tif")])
    assert r.exit_code == 2 and r.output.strip().splitlines() == [
        "Error: --window must be an even number of pixels (the window centres lie on pixel corners); got 127, use 128"]
    assert not (tmp_path / "d.tif").exists()


def test_featureless_target_is_refused_with_both_reasons(seasonal, tmp_path):
    """Neither features nor windows find anything on a smooth ramp: one error naming both, nothing written."""
    ref, _ = seasonal
    with rasterio.open(ref) as ds:
        shape, transform = ds.shape, ds.transform
    flat = cs.write_geotiff(tmp_path / "flat.tif", np.tile(np.linspace(20, 220, shape[1]), (shape[0], 1)), transform=transform, dtype="uint8")
    with pytest.raises(MatchingError) as e:
        register(ref, flat, tmp_path / "o.tif", local=True)
    assert "area-based matching did not help either" in str(e.value) and "valid" in str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["flat.tif"]
