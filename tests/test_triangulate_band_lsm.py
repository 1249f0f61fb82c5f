"""Least-squares matching of tie points between frames in other band sets (triangulate's LSM trial on combined
bands): a 3-band frame whose band mean is nearly flat against a one-band frame showing one band difference."""
import cv2
import numpy as np
import pytest
import rasterio

from fotogeo.io.raster import open_raster
from fotogeo.tools.triangulate import pairs

SHIFT = np.array([1.3, -0.7])


def _texture(size, seed):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.normal(size=(size, size)).astype(np.float32), (0, 0), 2.5)
    return t / t.std()


def _write(path, bands):
    with rasterio.open(path, "w", driver="GTiff", width=bands.shape[2], height=bands.shape[1], count=len(bands),
                       dtype="uint8") as ds:
        ds.write(np.clip(np.round(bands), 1, 255).astype(np.uint8))
    return open_raster(path, "frame")


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    folder, size = tmp_path_factory.mktemp("band_lsm"), 240
    t, other = _texture(size, 0), _texture(size, 1)
    rng = np.random.default_rng(2)
    # a: the structure lies in b1 - b2 (NIR-like), their mean holds a weak other texture only
    a = np.stack([128 + 30 * t + 6 * other, 128 - 30 * t + 6 * other, 128 + 6 * other])
    a = a + rng.normal(0, 1, (3, size, size))
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32)
    moved = cv2.remap(t, xx - SHIFT[0], yy - SHIFT[1], cv2.INTER_CUBIC)  # b(x) = t(x - shift)
    b = (128 + 45 * moved + rng.normal(0, 1, (size, size)))[None]
    return _write(folder / "a.tif", a), _write(folder / "b.tif", b)


def test_a_cross_band_pair_converges_on_the_combined_bands(frames):
    ia, ib = frames
    g = np.arange(40, 201, 20, dtype=float)
    anchors = np.array([(x, y) for y in g for x in g])
    xy = anchors + SHIFT + np.random.default_rng(3).uniform(-1, 1, anchors.shape)
    jac = np.broadcast_to(np.eye(2), (len(anchors), 2, 2)).copy()
    ok, got, sigma = pairs.lsm_pair(ia, ib, pairs.grey(ia), pairs.grey(ib), anchors, xy, jac, 10, 3.5, 0.1)
    plain_ok = pairs.lsm_group(pairs.grey(ia), pairs.grey(ib), anchors, xy, jac, 10, 3.5, 0.1)[0]
    assert plain_ok.sum() < 0.5 * len(anchors)  # the greys do not correspond
    assert ok.sum() >= 0.9 * len(anchors)
    err = np.hypot(*(got - (anchors[ok] + SHIFT)).T)
    assert np.median(err) < 0.1
    by_task = pairs.lsm_task(str(ia.path), str(ib.path), anchors, xy, jac, 10, 3.5, 0.1)  # the Dask path: the same
    assert all(np.array_equal(x, y) for x, y in zip(by_task, (ok, got, sigma)))


def test_a_pair_of_equal_band_counts_is_matched_on_its_greys(frames):
    ia, _ = frames
    g = np.arange(40, 201, 40, dtype=float)
    anchors = np.array([(x, y) for y in g for x in g])
    jac = np.broadcast_to(np.eye(2), (len(anchors), 2, 2)).copy()
    a = pairs.lsm_pair(ia, ia, pairs.grey(ia), pairs.grey(ia), anchors, anchors + 0.4, jac, 10, 3.5, 0.1)
    b = pairs.lsm_group(pairs.grey(ia), pairs.grey(ia), anchors, anchors + 0.4, jac, 10, 3.5, 0.1)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


def _planted(n, plain_ok, wide_ok, wide_offset):
    """``lsm_group`` stand-in: the plain run (narrow windows) converged on ``plain_ok`` at the truth, the wide run
    on ``wide_ok`` at the truth + ``wide_offset`` (n, 2)."""
    truth = np.column_stack([np.arange(n, dtype=float) * 20 + 40, np.full(n, 60.0)])

    def group(image_a, image_b, anchors, xy, jacobian, half_window, max_shift, min_sigma):
        ok, at = (plain_ok, truth) if half_window == 10 else (wide_ok, truth + wide_offset)
        return ok.copy(), at[ok], np.full(int(ok.sum()), 0.2)
    return truth, group


def test_a_wrong_wide_fit_is_not_accepted(frames, monkeypatch):
    ia, ib = frames
    n = 10
    plain_ok = np.arange(n) < 6
    wide_ok = np.ones(n, bool)  # more windows converge on the trial ...
    offset = np.zeros((n, 2))
    offset[:3] = (3.0, -2.0)  # ... but three of them far from where the plain run put them
    offset[3:6] = (0.3, 0.2)  # three agree within LSM's precision
    truth, group = _planted(n, plain_ok, wide_ok, offset)
    monkeypatch.setattr(pairs, "lsm_group", group)
    monkeypatch.setattr(pairs, "band_frames", lambda ba, bb, ga, gb, *a: (ga, gb))
    g = np.zeros((32, 32), np.float32)
    ok, got, sigma = pairs.lsm_pair(ia, ib, g, g, truth, truth, np.zeros((n, 2, 2)), 10, 3.5, 0.1)
    assert ok.tolist() == [False] * 3 + [True] * 7  # the disagreeing windows dropped, the wide-only ones added
    assert np.allclose(got, truth[3:])  # the plain fit where both agree
    assert len(sigma) == 7


def test_an_rgba_frame_beside_an_rgb_one_takes_the_equal_band_path(tmp_path, monkeypatch):
    size = 64
    t = 128 + 40 * _texture(size, 4)
    rgb = _write(tmp_path / "rgb.tif", np.stack([t, t, t]))
    with rasterio.open(tmp_path / "rgba.tif", "w", driver="GTiff", width=size, height=size, count=4, dtype="uint8",
                       photometric="RGB", alpha="YES") as ds:  # GDAL's ExtraSamples: the 4th band is alpha
        ds.write(np.clip(np.round(np.stack([t, t, t, np.full_like(t, 255)])), 1, 255).astype(np.uint8))
    rgba = open_raster(tmp_path / "rgba.tif", "frame")
    windows = []
    real = pairs.lsm_group
    monkeypatch.setattr(pairs, "lsm_group", lambda *a: windows.append(a[5]) or real(*a))
    anchors = np.array([[32.0, 32.0], [24.0, 40.0]])
    pairs.lsm_pair(rgba, rgb, pairs.grey(rgba), pairs.grey(rgb), anchors, anchors, np.broadcast_to(
        np.eye(2), (2, 2, 2)).copy(), 6, 3.5, 0.1)
    assert windows == [6]  # one run, on the greys: no band-set trial
    assert rgba.count == 4 and pairs.data_bands(rgba) == [0, 1, 2]


def test_a_pairs_band_sets_are_read_with_its_frames_not_opened_again(tmp_path, monkeypatch):
    """Which bands hold data (alpha left out) is read once, when :func:`open_raster` opens the frame
    (``RasterInfo.data_bands``): least-squares matching a pair whose greys are given opens no file."""
    t = 128 + 40 * _texture(64, 5)
    rgb = _write(tmp_path / "rgb.tif", np.stack([t, t, t]))
    with rasterio.open(tmp_path / "rgba.tif", "w", driver="GTiff", width=64, height=64, count=4, dtype="uint8",
                       photometric="RGB", alpha="YES") as ds:
        ds.write(np.clip(np.round(np.stack([t, t, t, np.full_like(t, 255)])), 1, 255).astype(np.uint8))
    rgba = open_raster(tmp_path / "rgba.tif", "frame")
    assert (rgb.data_bands, rgba.data_bands) == ((0, 1, 2), (0, 1, 2))
    greys, opened, real = (pairs.grey(rgba), pairs.grey(rgb)), [], rasterio.open
    monkeypatch.setattr(rasterio, "open", lambda *a, **k: opened.append(a[0]) or real(*a, **k))
    anchors = np.array([[32.0, 32.0], [24.0, 40.0]])
    pairs.lsm_pair(rgba, rgb, *greys, anchors, anchors, np.broadcast_to(np.eye(2), (2, 2, 2)).copy(), 6, 3.5, 0.1)
    assert opened == []


def test_a_mixed_pairs_frames_are_read_once_each_for_their_greys_and_bands(frames, monkeypatch):
    """A pair in other band sets is read at full resolution once per frame, its grey and its bands from the same
    read — in this process (the least-squares jobs' frame cache) and as a Dask task — with the results of the
    pair's greys and bands read apart."""
    ia, ib = frames
    g = np.arange(40, 201, 40, dtype=float)
    anchors = np.array([(x, y) for y in g for x in g])
    xy = anchors + SHIFT + np.random.default_rng(4).uniform(-1, 1, anchors.shape)
    jac = np.broadcast_to(np.eye(2), (len(anchors), 2, 2)).copy()
    want = pairs.lsm_pair(ia, ib, pairs.grey(ia), pairs.grey(ib), anchors, xy, jac, 10, 3.5, 0.1)
    reads, real = [], pairs.read_decimated
    monkeypatch.setattr(pairs, "read_decimated", lambda info, *a, **k: reads.append(str(info.path)) or real(
        info, *a, **k))
    (local,) = pairs._local_lsm([ia, ib], [(0, 1, anchors, xy, jac)], 10, 3.5, 0.1, lambda *a: True)
    assert sorted(reads) == sorted([str(ia.path), str(ib.path)])
    by_task = pairs.lsm_task(str(ia.path), str(ib.path), anchors, xy, jac, 10, 3.5, 0.1)
    assert sorted(reads) == sorted([str(ia.path), str(ib.path)] * 2)
    for got in (local, by_task):
        assert all(np.array_equal(x, y) for x, y in zip(got, want))
    assert want[0].sum() > 0
