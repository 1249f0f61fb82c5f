"""PCA band fusion: the first principal component of a multi-band image, robustly stretched.

For bands ``b = (b_1 … b_B)`` at the valid pixels, with mean ``μ`` and covariance ``C``
(estimated from a pixel sample on large images), the first principal component is
``pc1 = v₁ᵀ (b − μ)`` where ``v₁`` is the eigenvector of ``C`` with the largest eigenvalue.
Its sign is arbitrary, and a flip inverts contrast and ruins matching, so ``v₁`` is oriented
to correlate positively with the band mean (``Σ v₁ > 0``). Single-band images skip the PCA.

Bands that carry nothing — empty (no valid value: all nodata, NaN or masked) or constant over
their valid pixels — are left out of the PCA with a :class:`~fotogeo.errors.FotogeoWarning`
naming them (their weight in ``v₁`` is 0), so a Landsat-8-style stack with an empty or a
constant band still fuses; only an image without any band left is refused. A pixel is valid
where every band kept is finite and not all of them are ``nodata`` (GDAL's warper rule), and
``mask`` allows it.

``pc1`` is then mapped to 0..255 (float32) by one of three contrast methods:

* ``"linear"`` — the paper's robust stretch between the 1st and 99th percentiles, clipped;
* ``"equalize"`` — through the empirical distribution function of the valid pixels
  (``255 · F(pc1)``): monotonic like the linear stretch, but bright clouds, snow or a fill
  value cannot squeeze the land into a few grey levels;
* ``"adaptive"`` (default) — ``equalize`` followed by CLAHE (contrast-limited adaptive
  histogram equalisation, 8x8 tiles, clip limit 2), which evens out contrast between bright
  and dark parts of the scene. Measured with SURF + RANSAC inliers (linear → adaptive):
  Sentinel-2 two dates with clouds 5 → 557, NGI frame ↔ orthophoto 345 → 673, Sentinel-2 ↔
  NGI orthophoto 98 → 151.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import FotogeoWarning, InputError
from .contrast import CONTRASTS, apply_contrast


#: a band whose adjacent pixels correlate less than this is noise (:func:`band_content`) ...
NOISE = 0.2
#: ... when another band's correlate at least this much (an image of the ground: about 0.9 and more)
STRUCTURED = 0.5


@dataclass(frozen=True)
class Fusion:
    """Result of :func:`pca_fuse`."""

    image: np.ndarray  # (rows, cols) float32 in 0..255, 0 where invalid
    mask: np.ndarray  # (rows, cols) bool, True = valid
    component: np.ndarray  # (B,) unit eigenvector v1 (sign-fixed), 0 for the bands left out
    explained: float  # fraction of the variance carried by pc1
    stretch: tuple  # (low, high) pc1 values mapped to 0 and 255
    mean: np.ndarray | None = None  # (B,) band means μ at the valid pixels (0 for the bands left out)
    bands: tuple = ()  # band numbers (as named, 1-based) of the bands fused
    dropped: dict | None = None  # band number -> why it was left out ("empty", "constant 7")


def valid_mask(bands: np.ndarray, mask=None, nodata=None) -> np.ndarray:
    """Pixels valid in every band: finite, not ``nodata``, and ``mask`` True where given."""
    valid = np.isfinite(bands).all(axis=0) if bands.dtype.kind == "f" else np.ones(bands.shape[1:], bool)
    if nodata is not None and np.isfinite(nodata):
        valid &= ~(bands == nodata).all(axis=0)
    if mask is not None:
        valid &= np.asarray(mask, bool)
    return valid


def band_content(bands: np.ndarray, mask=None, nodata=None, numbers=None) -> dict:
    """Bands with nothing to fuse: ``{band number: "empty" | "constant <value>" | "noise, …"}``.

    A band is empty when none of its pixels is finite, not ``nodata`` and allowed by ``mask``
    (``(rows, cols)``, or ``(B, rows, cols)`` per band); constant when its valid values are all
    equal; noise when its :func:`neighbour_correlation` is below ``NOISE`` while another band's
    reaches ``STRUCTURED`` (a band of noise louder than the image would otherwise be the first
    principal component: the variance PCA maximises is not the signal matching needs; Green et
    al. 1988 order components by signal-to-noise for that reason). ``numbers`` name the bands
    (default 1..B).

    >>> b = np.stack([np.arange(12.0).reshape(3, 4), np.full((3, 4), 7.0), np.zeros((3, 4))])
    >>> band_content(b, nodata=0)
    {2: 'constant 7', 3: 'empty'}
    """
    a = np.asarray(bands)
    numbers = range(1, len(a) + 1) if numbers is None else numbers
    allowed = None if mask is None else np.broadcast_to(np.asarray(mask, bool), a.shape)
    out, rho = {}, {}
    for i, (n, b) in enumerate(zip(numbers, a)):
        ok = np.isfinite(b) if b.dtype.kind == "f" else np.ones(b.shape, bool)
        if nodata is not None and np.isfinite(nodata):
            ok &= b != nodata
        if allowed is not None:
            ok &= allowed[i]
        values = b if ok.all() else b[ok]
        if values.size == 0:
            out[int(n)] = "empty"
        elif values.min() == values.max():
            out[int(n)] = f"constant {values.flat[0]:g}"
        else:
            rho[int(n)] = neighbour_correlation(b, ok)
    if rho and max(rho.values()) >= STRUCTURED:
        out.update({n: f"noise, neighbour correlation {r:.2f}" for n, r in rho.items() if r < NOISE})
    return dict(sorted(out.items()))


def neighbour_correlation(band: np.ndarray, ok=None, max_pairs: int = 1_000_000) -> float:
    """The correlation of horizontally adjacent valid pixels of ``band`` (``ok`` marks them; rows taken at a
    stride so that at most about ``max_pairs`` pairs enter): about 1 for an image of the ground, 0 for noise."""
    step = max(1, int(band.size // max(max_pairs, 1)))
    b = np.asarray(band[::step], np.float64)
    ok = np.ones(b.shape, bool) if ok is None else np.asarray(ok[::step], bool)
    both = ok[:, :-1] & ok[:, 1:]
    x, y = b[:, :-1][both], b[:, 1:][both]
    if x.size < 16 or x.std() == 0 or y.std() == 0:
        return 1.0
    return float(np.corrcoef(x, y)[0, 1])


def _component(bands, mask, nodata, sample, rng, name, numbers) -> tuple:
    """``(bands kept, band count, keep, valid, sample X, v1, mean, explained, numbers, dropped)`` of the module
    docstring's first principal component: the part :func:`pca_fuse` and :func:`band_weights` share."""
    a = np.asarray(bands)
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or min(a.shape) == 0:
        raise InputError(f"{name}: expected bands of shape (bands, rows, cols); got {np.shape(bands)}")
    numbers = tuple(int(n) for n in (range(1, a.shape[0] + 1) if numbers is None else numbers))
    if len(numbers) != a.shape[0]:
        raise InputError(f"{name}: {len(numbers)} band numbers for {a.shape[0]} bands")
    dropped = band_content(a, mask, nodata, numbers) if a.shape[0] > 1 else {}
    keep = np.array([n not in dropped for n in numbers])
    if not keep.any():
        empty = all(w == "empty" for w in dropped.values())
        raise InputError(f"{name}: " + ("no valid pixels in any band (all nodata, NaN or masked); check its nodata "
                                        "value and mask" if empty else
                                        f"no band to fuse, every band is constant or empty ({_listing(dropped)}): "
                                        f"there is no contrast to match; check the band selection and nodata"))
    if dropped:
        warnings.warn(f"{name}: band{'s' if len(dropped) > 1 else ''} {_listing(dropped)} left out of the PCA "
                      f"fusion (nothing to match in {'them' if len(dropped) > 1 else 'it'}); fused bands "
                      f"{', '.join(str(n) for n, k in zip(numbers, keep) if k)}", FotogeoWarning, stacklevel=3)
    full = a.shape[0]
    a = a[keep] if not keep.all() else a
    if mask is not None and np.ndim(mask) == 3:
        mask = np.asarray(mask, bool)[keep].all(axis=0)
    valid = valid_mask(a, mask, nodata)
    idx = np.flatnonzero(valid)
    if idx.size < 16:
        raise InputError(f"{name}: no valid pixels (all nodata, NaN or masked); check its nodata value and mask")
    if idx.size > sample:
        idx = np.sort(np.random.default_rng(rng).choice(idx, sample, replace=False))
    X = a.reshape(a.shape[0], -1)[:, idx].astype(np.float64)
    mean = X.mean(axis=1)
    if a.shape[0] == 1:
        v, explained = np.ones(1), 1.0
    else:
        C = np.cov(X)
        w, V = np.linalg.eigh(C)
        v = V[:, -1]
        explained = float(w[-1] / w.sum()) if w.sum() > 0 else 1.0
        if v.sum() < 0:
            v = -v
    return a, full, keep, valid, X, v, mean, explained, numbers, dropped


def band_weights(bands, mask=None, *, nodata=None, sample: int = 200_000, rng=0, name: str = "image") -> np.ndarray:
    """Weights ``(B,)`` of ``bands`` ``(B, rows, cols)``: the first principal component ``v₁`` of the bands kept
    (module docstring; 0 for the bands left out) divided by ``Σ |v₁|``. ``Σ w_b b_b`` is then a grey image in the
    bands' own units (the plain mean when the bands are equal; bands that correlate, as an image's do, all weigh
    positively and sum to 1), with the contrast the PCA finds and without the bands that carry nothing (empty,
    constant, noise)."""
    _, full, keep, _, _, v, _, _, _, _ = _component(bands, mask, nodata, sample, rng, name, None)
    w = np.zeros(full)
    w[keep] = v / np.abs(v).sum()
    return w


def pca_fuse(bands, mask=None, *, nodata=None, sample: int = 1_000_000, rng=0,
             percentiles=(1.0, 99.0), contrast: str = "linear", name: str = "image", numbers=None) -> Fusion:
    """First principal component of ``bands`` ``(B, rows, cols)`` (or a 2-D single band).

    ``mask`` marks valid pixels, ``(rows, cols)`` or per band ``(B, rows, cols)`` (a pixel is then
    valid where every band fused allows it); ``nodata`` values and NaN are excluded too. Statistics use
    at most ``sample`` pixels drawn with the seed ``rng``. ``contrast`` is one of
    :data:`CONTRASTS` (see the module docstring). ``name`` appears in errors and warnings,
    ``numbers`` (default 1..B) name the bands there: empty or constant bands are left out
    with a :class:`~fotogeo.errors.FotogeoWarning`, and only an image without a band left is
    refused (:class:`~fotogeo.errors.InputError`).

    Two perfectly correlated bands fuse into one band carrying all the variance, stretched
    to 0..255 (float32, the shape of one band):

    >>> x = np.arange(20.0).reshape(4, 5)
    >>> f = pca_fuse(np.stack([x, 2 * x + 1]))
    >>> f.image.shape, f.image.dtype, f.mask.all()
    ((4, 5), dtype('float32'), True)
    >>> f.component.round(3).tolist(), round(f.explained, 3)
    ([0.447, 0.894], 1.0)
    >>> float(f.image[0, 0]), float(f.image[-1, -1])
    (0.0, 255.0)
    """
    if contrast not in CONTRASTS:
        raise InputError(f"contrast {contrast!r} unknown; choose one of {', '.join(CONTRASTS)}")
    a, full, keep, valid, X, v, mean, explained, numbers, dropped = _component(bands, mask, nodata, sample, rng, name,
                                                                              numbers)
    s = v @ (X - mean[:, None])
    lo, hi = np.percentile(s, percentiles)
    if not hi > lo:
        lo, hi = float(s.min()), float(s.max())
    if not hi > lo:
        raise InputError(f"{name}: the image is constant over its valid pixels (no contrast to match)")
    out = np.zeros(a.shape[1:], np.float32)
    k = 255.0 / (hi - lo)
    rows_per_chunk = max(1, 4_000_000 // max(1, a.shape[2]))
    for r0 in range(0, a.shape[1], rows_per_chunk):  # bounded memory on large images
        blk = a[:, r0:r0 + rows_per_chunk].astype(np.float32)
        pc = np.tensordot(v.astype(np.float32), blk - mean[:, None, None].astype(np.float32), axes=1)
        out[r0:r0 + rows_per_chunk] = np.clip((pc - lo) * k, 0, 255)
    out[~valid] = 0
    component, means = np.zeros(full), np.zeros(full)
    component[keep], means[keep] = v, mean
    return Fusion(apply_contrast(out, valid, contrast), valid, component, explained, (float(lo), float(hi)), means,
                  tuple(n for n, k in zip(numbers, keep) if k), dropped)


def _listing(dropped: dict) -> str:
    """``{4: "constant 7", 5: "empty"}`` → ``"4 (constant 7), 5 (empty)"``."""
    return ", ".join(f"{n} ({why})" for n, why in dropped.items())
