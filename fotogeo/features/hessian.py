"""SURF detector: box-filter Hessian on an integral image, 3x3x3 maxima, quadratic refinement.

Conventions of this module (internal to :mod:`fotogeo.features`): positions are in the
*centre* convention (pixel ``[r, c]`` has its centre at ``(x, y) = (c, r)``); the public
:func:`fotogeo.features.surf` converts once with :func:`fotogeo.pixels.from_centre`.

Integral image (of the image padded by ``pad`` pixels on every side, reflect-101; each
octave gets its own, see :func:`octave_integrals`)::

    ii[R, C] = sum(img[:R, :C]),   box(r0:r1, c0:c1) = ii[r1,c1] - ii[r0,c1] - ii[r1,c0] + ii[r0,c0]

Box filters of odd size L = 3 l (Bay et al. 2008, fig. 1), centred on pixel (r, c):

    Dxx = box(rows r-l+1 .. r+l-1, cols c-(3l-1)/2 .. c+(3l-1)/2) - 3 box(same rows, cols c-(l-1)/2 .. c+(l-1)/2)
    Dyy = Dxx transposed
    Dxy = box(TL) + box(BR) - box(TR) - box(BL),  four l x l lobes around (r, c) with a 1-pixel gap

each divided by the filter area L^2, and the blob response

    det(H) = Dxx Dyy - (w Dxy)^2,       laplacian = sign(Dxx + Dyy),   w = DXY_WEIGHT (1.0).

The threshold is on det(H) in (grey level)^2: for an image in 0..255 it has the meaning of
OpenCV's ``hessianThreshold``; for an image scaled by k it scales by k^2.

Scale space (Bay et al. 2008, sec. 3.3): octave o samples every p = 2^o pixels with filter
sizes 9, 15, 21, 27 (o = 0), 15, 27, 39, 51 (o = 1), 27, 51, 75, 99, ... (the step between
sizes doubles per octave); SURF scale s = 1.2 L / 9. Maxima over the 26 neighbours in
(x, y, layer) of the two middle layers are refined by the Newton step ``d = -H^-1 g`` of a
quadratic fit and rejected when any component of ``d`` exceeds :data:`MAX_OFFSET` sample
units (1, as OpenCV; see there why not Lowe's 0.5). Octave o+1 repeats the scales between octave
o's top layers (e.g. a blob of size 23 peaks at L=21 in octave 0 and at L=27 in octave 1):
such duplicates are dropped from the coarser octave (interpolated size below
``L2(o) + step(o)/2``), else the ratio test would reject both copies.

Unlike Bay et al., octave o >= 1 filters a copy of the image smoothed to sigma = 2^o
pixels (its sampling step), and its keypoints are described on that copy too, see
:data:`OCTAVE_BLUR`: that made SURF clearly more repeatable and distinctive under rotation
and scale on real images.

With ``gaussian=True`` (:func:`detect`; the default of :func:`fotogeo.features.surf`) each
layer's Dxx, Dyy, Dxy are instead the derivatives of a Gaussian of sigma s = 1.2 L / 9 on the
same smoothed octave image, taken every 2^o pixels (:func:`_gauss_layer`): the scale-normalised
det(H) of Lindeberg (1998), rotation covariant where the boxes are not; scales, sampling,
maxima and refinement are unchanged. That size cut does not separate the Gaussian layers'
octaves (octave o's image is smoothed to 2^o, so one blob peaks at a larger s the coarser the
octave): :mod:`fotogeo.features.octaves` drops the second copy.

The response maps are computed in bands of sample rows (with a one-row halo for the
non-maximum suppression), so memory stays bounded on large images; each row belongs to
exactly one band interior, so bands never produce duplicates.
"""
from __future__ import annotations

import cv2
import numpy as np

#: Largest accepted Newton offset (sample units). Lowe's 0.5 (beyond it the maximum
#: "belongs" to a neighbouring sample) loses blobs centred exactly between two samples:
#: there the quadratic model's cross terms give about 0.51, and the neighbour is no maximum
#: (plateaus yield one maximum, see the tie-break in :func:`_maxima`). With 1.0 (OpenCV's
#: limit) repeatability rose 0.669 -> 0.685 and matching score 0.560 -> 0.575 on the
#: benchmark's rotation/scale cases (2 images, 6 transforms, top-1000 keypoints).
MAX_OFFSET = 1.0

#: Octave o >= 1 (response sampled every 2^o pixels) sees the image smoothed with a
#: Gaussian of sigma = OCTAVE_BLUR * 2^o: an anti-aliasing blur for its sub-sampled response
#: maps that also makes the large box filters behave more like the Gaussian derivatives they
#: approximate (more isotropic, so better under rotation). Measured on the benchmark's
#: rotation/scale cases (3 real images x 7 transforms, top-1000 keypoints): repeatability /
#: matching score / ratio-test score 0.753 / 0.703 / 0.646 without it, 0.795 / 0.748 / 0.684
#: at 0.8, 0.814 / 0.760 / 0.698 at 1.0, 0.815 / 0.756 / 0.699 at 1.2, 0.792 / 0.734 / 0.680
#: at 1.4, 0.722 / 0.659 / 0.613 at 1.8 (rotation 30 deg alone: 0.669 -> 0.74). Orientation
#: and descriptor of an octave's keypoints use the same smoothed image: 0.760 / 0.698 ->
#: 0.768 / 0.724 (matching / ratio-test score; 0.7x or 1.5x that sigma did worse). A departure
#: from Bay et al., who filter the raw image at every scale; 0 restores that.
OCTAVE_BLUR = 1.0

#: Weight w of Dxy in det(H) = Dxx Dyy - (w Dxy)^2. Bay et al. (2008) take 0.9 from the
#: Frobenius norms of the 9x9 filters and the Gaussian derivatives; for det(H) to be rotation
#: invariant, (Dxx - Dyy) and 2 w Dxy must respond equally to a saddle (x^2 - y^2) g and its
#: 45-degree rotation 2xy g, g the Gaussian of the filter's scale: that gives w = 0.93-1.12
#: over the filter sizes and octave smoothings used here (1.0 for most). Measured on the
#: benchmark's rotation, scale and rotation+scale cases (3 real images, 14 transforms):
#: repeatability / matching score 0.8005 / 0.7738 at 0.9, 0.8060 / 0.7793 at 1.0.
DXY_WEIGHT = 1.0

#: Factor K of the Gaussian layers' det(H) = K s^4 (Lxx Lyy - Lxy^2) (:func:`_gauss_layer`), so
#: that a threshold keeps about the box filters' meaning: at threshold 50 the box filters gave
#: 1983 / 2256 / 368 keypoints (NGI frame 0182, orthophoto 1, Landsat; ``upscale=False``), the
#: unscaled Gaussian layers as many at a threshold of 80-100 (2351-1806, 2541-1945, 557-504).
GAUSSIAN_GAIN = 0.55

#: Target number of response samples per band and layer (bounds peak memory).
BAND_SAMPLES = 1 << 18


def octave_sizes(octave: int) -> list[int]:
    """Filter sizes of the four layers of ``octave`` (Bay et al.: 9,15,21,27; 15,27,39,51; ...)."""
    step = 6 << octave
    first = 3 * (1 << (octave + 1)) + 3 if octave else 9  # 9, 15, 27, 51, 99, ...
    return [first + step * i for i in range(4)]


def scale_of_size(size):
    """SURF scale s of a filter of size L: s = 1.2 L / 9."""
    return 1.2 * np.asarray(size, dtype=np.float64) / 9.0


def integral(img: np.ndarray, pad: int) -> np.ndarray:
    """float64 integral image of ``img`` padded by ``pad`` pixels (reflect-101) on every side.

    Shape ``(rows + 2 pad + 1, cols + 2 pad + 1)``; image pixel ``[r, c]`` is padded pixel
    ``[r + pad, c + pad]``.
    """
    src = np.ascontiguousarray(img, dtype=np.float32)
    if pad > 0:
        src = cv2.copyMakeBorder(src, pad, pad, pad, pad, cv2.BORDER_REFLECT_101)
    return cv2.integral(src, sdepth=cv2.CV_64F)


def _sub32(a, b):
    """a - b computed in float64 (integral values are large), stored as float32."""
    if a.strides[1] == a.itemsize and b.strides[1] == b.itemsize:   # rows contiguous: OpenCV
        return cv2.subtract(a, b, dtype=cv2.CV_32F)
    out = np.empty(a.shape, np.float32)
    np.subtract(a, b, out=out, casting="unsafe")
    return out


def _layer(ii, pad, r0, nr, nc, p, size):
    """det(H) and trace of one filter ``size`` on the sample grid rows ``r0 + p*k`` (k < nr),
    cols ``p*j`` (j < nc). Returns two float32 arrays ``(nr, nc)``; the trace is not
    normalised (only its sign is used)."""
    l = size // 3
    h = (size - 1) // 2          # half size
    m = (l - 1) // 2             # half width of the middle lobe
    rr = pad + r0                # padded row of the first sample
    rend = rr + p * (nr - 1) + 1  # stop (exclusive) for a strided slice starting at rr
    c_lo = pad - h - 1           # integral columns needed: [c_lo, c_hi)
    c_hi = pad + p * (nc - 1) + h + 2
    cc = pad - c_lo              # column of the first sample within the restricted slice
    cend = cc + p * (nc - 1) + 1

    def rows(off):  # integral rows r + off for every sample row, needed columns only
        return ii[rr + off:rend + off:p, c_lo:c_hi]

    def cols(a, off):  # columns c + off for every sample column
        return a[:, cc + off:cend + off:p]

    # Differences of two integral rows (or columns) are computed in float64 and stored as
    # float32: they are cumulative strip sums (up to 255 x lobe height x image width), so
    # float32 keeps them to ~1e-7 relative -- an error of ~1e-4 on a normalised Dxx, far
    # below any useful threshold (tests compare with a float64 reference).
    # Dxx: rows [r-l+1, r+l), whole lobe cols [c-h, c+h+1), middle [c-m, c+m+1)
    v = _sub32(rows(l), rows(-l + 1))
    dxx = cols(v, h + 1) - cols(v, -h)
    mid = cols(v, m + 1) - cols(v, -m)
    mid *= 3.0
    dxx -= mid
    # Dyy: the transpose. v[i] = strip sum of integral row (rr - h + i) over cols [c-l+1, c+l)
    ccs = ii[rr - h:rend + h + 1, c_lo:c_hi]
    v = _sub32(cols(ccs, l), cols(ccs, -l + 1))

    def vrows(off):  # integral rows r + off
        return v[h + off:h + off + p * (nr - 1) + 1:p]

    dyy = vrows(h + 1) - vrows(-h)
    mid = vrows(m + 1) - vrows(-m)
    mid *= 3.0
    dyy -= mid
    # Dxy: top lobes rows [r-l, r), bottom [r+1, r+1+l); left cols [c-l, c), right [c+1, c+1+l)
    d = _sub32(rows(0), rows(-l))
    d -= _sub32(rows(l + 1), rows(1))
    dxy = cols(d, 0) - cols(d, -l)
    dxy -= cols(d, l + 1) - cols(d, 1)
    # det = (Dxx Dyy - (w Dxy)^2) / L^4
    trace = dxx + dyy
    dxy *= np.float32(DXY_WEIGHT)
    dxy *= dxy
    dxx *= dyy
    dxx -= dxy
    dxx *= np.float32(1.0 / float(size) ** 4)
    return dxx, trace


def _gauss_kernels(sigma: float):
    """1-D Gaussian, first- and second-derivative correlation kernels of ``sigma``, each exact on
    polynomials (sum g = 1, sum g1 u = 1, sum g2 u^2 / 2 = 1, sum g2 = 0)."""
    r = int(np.ceil(4 * sigma))
    u = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-u * u / (2 * sigma * sigma))
    g /= g.sum()
    g1 = u * g
    g1 /= (g1 * u).sum()
    g2 = (u * u - (u * u * g).sum()) * g
    g2 /= (g2 * u * u / 2).sum()
    return r, g.astype(np.float32), g1.astype(np.float32), g2.astype(np.float32)


def _gauss_layer(img, r0, nr, nc, p, size):
    """As :func:`_layer`, with the derivatives of a Gaussian of sigma s = 1.2 L / 9 in place of the
    box filters of size L, on the same image taken every p-th pixel (octave o's image is already
    smoothed to sigma p = 2^o, so the decimation adds little aliasing):

        det(H) = K s^4 (Lxx Lyy - Lxy^2),   K = GAUSSIAN_GAIN,

    the scale-normalised determinant of the Hessian (Lindeberg 1998), rotation covariant where the
    9-195 px boxes are not (a box Dxy and Dxx respond unequally to a saddle and its 45-degree
    rotation, and the boxes' corners favour the axes)."""
    sigma = float(scale_of_size(size)) / p          # in samples of the octave
    r, g, g1, g2 = _gauss_kernels(sigma)
    rows = img.shape[0]
    want = np.abs(r0 + p * np.arange(-r, nr + r))
    want = np.where(want > rows - 1, 2 * (rows - 1) - want, want)   # reflect-101 rows
    band = np.ascontiguousarray(img[np.clip(want, 0, rows - 1), :p * (nc - 1) + 1:p], dtype=np.float32)

    def filt(kx, ky):
        out = cv2.sepFilter2D(band, cv2.CV_32F, kx, ky, borderType=cv2.BORDER_REFLECT_101)
        return out[r:r + nr]
    lxx, lyy, lxy = filt(g2, g), filt(g, g2), filt(g1, g1)
    k = np.float32(GAUSSIAN_GAIN * sigma ** 4)     # (s/p)^4 det in samples = s^4 det in pixels
    det = (lxx * lyy - lxy * lxy) * k
    return det.astype(np.float32), lxx + lyy


def central_differences(v):
    """Value, gradient and Hessian in (x, y, s) from the 3 x 3 x 3 neighbourhood ``v(ds, dy, dx)``
    (each an array over the points; offsets -1, 0, 1): central differences, the quadratic a Newton
    step of a scale-space extremum solves (Brown & Lowe 2002). Returns ``(c, g (N, 3), H (N, 3, 3))``."""
    c = v(0, 0, 0)
    g = np.stack([(v(0, 0, 1) - v(0, 0, -1)) / 2, (v(0, 1, 0) - v(0, -1, 0)) / 2,
                  (v(1, 0, 0) - v(-1, 0, 0)) / 2], -1)
    hxx = v(0, 0, 1) + v(0, 0, -1) - 2 * c
    hyy = v(0, 1, 0) + v(0, -1, 0) - 2 * c
    hss = v(1, 0, 0) + v(-1, 0, 0) - 2 * c
    hxy = (v(0, 1, 1) - v(0, 1, -1) - v(0, -1, 1) + v(0, -1, -1)) / 4
    hxs = (v(1, 0, 1) - v(1, 0, -1) - v(-1, 0, 1) + v(-1, 0, -1)) / 4
    hys = (v(1, 1, 0) - v(1, -1, 0) - v(-1, 1, 0) + v(-1, -1, 0)) / 4
    hm = np.stack([np.stack([hxx, hxy, hxs], -1), np.stack([hxy, hyy, hys], -1),
                   np.stack([hxs, hys, hss], -1)], -2)
    return c, g, hm


def _refine(det, cand_layer, k, j):
    """Quadratic (Newton) refinement around maxima at ``det[cand_layer, k, j]``.

    Returns offsets (dx, dy, dlayer) and a boolean ``ok`` (all |offset| <= MAX_OFFSET, finite).
    """
    L, K, J = cand_layer, k, j

    def v(dl, dk, dj):
        return det[L + dl, K + dk, J + dj].astype(np.float64)

    c, g, hm = central_differences(v)
    detm = np.linalg.det(hm) if len(c) else np.zeros(0)
    ok = np.abs(detm) > 1e-30
    off = np.zeros_like(g)
    if ok.any():
        off[ok] = -np.linalg.solve(hm[ok], g[ok][..., None])[..., 0]
    ok &= np.all(np.abs(off) <= MAX_OFFSET, axis=1) & np.all(np.isfinite(off), axis=1)
    return off, ok


def octave_pad(octave: int, window: float, rows: int, cols: int) -> int:
    """Padding of octave ``octave``'s integral image: half its largest filter plus 2, or the
    reach ``window * s`` of a descriptor at its largest scale s, whichever is larger."""
    big = octave_sizes(octave)[-1]
    pad = max(big // 2 + 2, int(np.ceil(window * float(scale_of_size(big)))) + 2)
    return min(pad, max(big // 2 + 2, 4 * max(rows, cols)))


def octave_integrals(img: np.ndarray, n_octaves: int, blur: float = 0.0, window: float = 0.0):
    """Yield ``(octave, integral image, its padding, smoothed image)`` for each octave.

    Octave o's integral is of ``img`` smoothed to sigma ``OCTAVE_BLUR * 2^o`` (never less
    than the ``blur`` already in ``img``), padded by :func:`octave_pad` (``window``: the
    descriptor reach in units of s; 0 for detection alone). Holds one integral image and one
    smoothed copy at a time, if the caller drops the yielded integral before the next.
    """
    rows, cols = img.shape
    for o in range(n_octaves):
        sigma = OCTAVE_BLUR * (1 << o)
        if sigma > blur:
            img = cv2.GaussianBlur(img, (0, 0), float(np.sqrt(sigma ** 2 - blur ** 2)),
                                   borderType=cv2.BORDER_REFLECT_101)
            blur = sigma
        pad = octave_pad(o, window, rows, cols)
        yield o, integral(img, pad), pad, img


def detect(img: np.ndarray, threshold: float, n_octaves: int, blur: float = 0.0, gaussian: bool = False):
    """Detect SURF keypoints in a float32 image (no NaN).

    Returns a dict of arrays: ``x``, ``y`` (centre convention), ``size`` (interpolated
    filter size L), ``response`` (det(H) at the maximum), ``laplacian`` (int8 ±1) and
    ``octave`` (int). ``blur``: Gaussian sigma already applied to ``img``; octaves smooth it
    further, see :func:`octave_integrals`. ``gaussian``: Gaussian-derivative layers
    (:func:`_gauss_layer`) instead of box filters (the scales, sampling and maxima unchanged).
    """
    rows, cols = img.shape
    out = {k: [] for k in ("x", "y", "size", "response", "laplacian", "octave")}
    for o, ii_o, pad, img_o in octave_integrals(img, n_octaves, blur):
        p = 1 << o
        sizes = octave_sizes(o)
        nr_all = -(-rows // p)
        nc = -(-cols // p)
        if nr_all < 3 or nc < 3:
            break
        band = max(8, BAND_SAMPLES // max(nc, 1))
        for k0 in range(0, nr_all, band):
            k1 = min(nr_all, k0 + band)
            h0, h1 = max(0, k0 - 1), min(nr_all, k1 + 1)  # with one-row halo
            nr = h1 - h0
            if nr < 3:
                continue
            if gaussian:
                maps = [_gauss_layer(img_o, h0 * p, nr, nc, p, sz) for sz in sizes]
            else:
                maps = [_layer(ii_o, pad, h0 * p, nr, nc, p, sz) for sz in sizes]
            det = np.stack([m[0] for m in maps])
            for li in (1, 2):
                _maxima(det, maps[li][1], li, sizes, o, p, h0, k0, k1, rows, cols, threshold, out)
        del ii_o                                # before the next octave's integral is built
    if not out["x"]:
        return {k: np.zeros(0, dtype=np.int8 if k in ("laplacian", "octave") else np.float64) for k in out}
    return {k: np.concatenate(v) for k, v in out.items()}


def _maxima(det, trace, li, sizes, o, p, h0, k0, k1, rows, cols, threshold, out):
    """3x3x3 maxima of layer ``li`` in the band interior rows [k0, k1), refined; appends to out."""
    # Ties (e.g. a blob centred between pixels) are broken in raster/layer order: a sample
    # must be >= every neighbour and > those that come before it (the smaller layer, and
    # the previous row and the left neighbour in its own layer), so a plateau yields one maximum.
    cur = det[li]
    full = np.ones((3, 3), np.uint8)
    before = np.array([[1, 1, 1], [1, 0, 0], [0, 0, 0]], np.uint8)
    is_max = (cur > threshold) & (cur >= cv2.dilate(det[li + 1], full))
    is_max &= cur > cv2.dilate(det[li - 1], full)
    is_max &= cur >= cv2.dilate(cur, full)
    is_max &= cur > cv2.dilate(cur, before, borderType=cv2.BORDER_CONSTANT, borderValue=-np.inf)
    # the next-larger filter must fit inside the image one sample around the candidate
    big = sizes[li + 1] // 2 + p
    nr, nc = cur.shape
    kk = h0 + np.arange(nr)
    row_ok = (kk >= k0) & (kk < k1) & (kk * p - big >= 0) & (kk * p + big <= rows - 1)
    jj = np.arange(nc)
    col_ok = (jj * p - big >= 0) & (jj * p + big <= cols - 1)
    is_max &= row_ok[:, None] & col_ok[None, :]
    # also keep the 1-sample neighbourhood inside the band arrays
    is_max[0, :] = is_max[-1, :] = False
    is_max[:, 0] = is_max[:, -1] = False
    k, j = np.nonzero(is_max)
    if not len(k):
        return
    off, ok = _refine(det, np.full(len(k), li), k, j)
    k, j, off = k[ok], j[ok], off[ok]
    step = sizes[1] - sizes[0]
    size = sizes[li] + off[:, 2] * step
    if o > 0:
        # Octaves overlap in scale: a blob between the finer octave's top layer and this
        # octave's first middle layer is a maximum in both. The finer octave (denser
        # sampling) owns sizes below its top middle layer plus half its step.
        prev = octave_sizes(o - 1)
        keep = size >= prev[2] + (prev[1] - prev[0]) / 2
        k, j, off, size = k[keep], j[keep], off[keep], size[keep]
    out["x"].append((j + off[:, 0]) * p)
    out["y"].append((h0 + k + off[:, 1]) * p)
    out["size"].append(size)
    out["response"].append(cur[k, j].astype(np.float64))
    out["laplacian"].append(np.where(trace[k, j] > 0, 1, -1).astype(np.int8))
    out["octave"].append(np.full(len(k), o, np.int8))


