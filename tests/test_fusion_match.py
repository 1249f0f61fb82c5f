"""PCA band fusion and descriptor matching (array layer)."""
import numpy as np
import pytest
import rasterio

from fotogeo.errors import InputError
from fotogeo.features.match import match_descriptors
from fotogeo.image.fusion import pca_fuse


def test_pca_sign_and_stretch_follow_the_band_mean(rng):
    base = rng.normal(100, 20, (64, 64))
    bands = np.stack([base * 1.0, base * 0.8 + 10, base * 1.2 - 5]) + rng.normal(0, 1, (3, 64, 64))
    f = pca_fuse(bands)
    assert f.explained > 0.99 and (f.component > 0).all()
    assert np.corrcoef(f.image.ravel(), base.ravel())[0, 1] > 0.99  # no contrast inversion
    assert f.image.min() >= 0 and f.image.max() <= 255
    # inverted band order or negated offsets do not flip the sign
    g = pca_fuse(bands[::-1] + 50)
    assert np.corrcoef(g.image.ravel(), base.ravel())[0, 1] > 0.99


def test_nodata_and_masks_are_excluded(rng):
    bands = rng.integers(1, 255, (3, 50, 60)).astype(np.uint8)
    bands[:, :10] = 0
    f = pca_fuse(bands, nodata=0)
    assert not f.mask[:10].any() and f.mask[10:].all() and (f.image[:10] == 0).all()
    with pytest.raises(InputError, match="no valid pixels"):
        pca_fuse(np.zeros((3, 20, 20), np.uint8), nodata=0)
    with pytest.raises(InputError, match="constant"):
        pca_fuse(np.full((3, 20, 20), 7.0))
    single = pca_fuse(bands[0], nodata=0)
    assert single.image.shape == (50, 60) and single.explained == 1.0


def test_pca_on_real_landsat(data_dir):
    with rasterio.open(data_dir / "landsat_rgb" / "RGB.byte.tif") as ds:
        f = pca_fuse(ds.read(), nodata=ds.nodata)
    assert f.explained > 0.8 and (f.component > 0).all()
    assert f.mask.mean() < 1.0  # the nodata collar is excluded


def test_ratio_test_mutual_and_laplacian(rng):
    a = rng.normal(size=(200, 64)).astype(np.float32)
    perm = rng.permutation(200)
    b = a[perm] + rng.normal(0, 0.01, (200, 64)).astype(np.float32)
    m = match_descriptors(a, b, ratio=0.8)
    assert len(m) == 200 and (perm[m.pairs[:, 1]] == m.pairs[:, 0]).all()
    # a decoy nearly as close as the true neighbour fails the ratio test
    b2 = np.vstack([b, b[:1] + 0.001])
    m2 = match_descriptors(a, b2, ratio=0.8)
    assert perm[0] not in m2.pairs[:, 0] and len(m2) == 199
    # Laplacian signs split the search
    la = np.where(np.arange(200) % 2 == 0, 1, -1)
    lb = la[perm]
    lb[:20] *= -1
    m3 = match_descriptors(a, b, laplacian1=la, laplacian2=lb)
    assert len(m3) == 180
    with pytest.raises(InputError):
        match_descriptors(a, b[:, :32])
