"""One pair of a block's frames matched or least-squares matched, and every pair as Dask tasks (the tool layer of
``fotogeo triangulate``).

A pair's matches (:func:`fotogeo.tools.register.match.find_tie_points`) are kept when they fit the two-view geometry:
a RANSAC fundamental matrix (Fischler & Bolles 1981) on the keypoints with the camera's distortion removed
(:func:`ideal_pixels`; a fundamental matrix holds for a pinhole camera only), :func:`epipolar_kept`.

**Pairs as Dask tasks** (:func:`dask_pair_results`; ``--scheduler`` / ``--workers``, the options and the
cluster of ``register-batch``, :func:`fotogeo.tools.common.dask_cluster.connect`): one task per frame detects its
keypoints (:func:`frame_features`; read, fused and detected once, as :class:`fotogeo.tools.register.match.FeatureCache`
does in one process), one task per pair matches the descriptors of its two frames' tasks and runs the
RANSAC (:func:`match_pair`); after the tracks are built and thinned (in the calling process), one task per
frame pair transfers the tracks anchored in one frame into the other by least-squares matching
(:func:`lsm_task`, :func:`lsm_group`; Gruen 1985). Tasks take paths (every worker must see the frames: a
shared file system) and run with GDAL, OpenCV and BLAS pinned to one thread; a frame's keypoints are
released by the scheduler once its last pair has run. The results are gathered in pair order, so the tracks built from them (and the LSM
results written into them) are the ones of the in-process path, whatever order the workers finish in.
"""
from __future__ import annotations

import uuid
from contextlib import contextmanager
from dataclasses import replace

import cv2
import numpy as np

from ...errors import Cancelled, MatchingError
from ...geometry.brown import coefficients
from ...geometry.camera import OrientedFrame
from ...io.raster import open_raster, read_decimated
from ...progress import as_progress
from ..register.match import FeatureCache, find_tie_points


def ideal_pixels(camera, distortion):
    """``xy (n, 2) -> (n, 2)``: measured pixels → the pixels of the distortion-free pinhole camera
    (the ray of :func:`fotogeo.orientation.bundle_jacobian.undistort_rays` put back through the pinhole,
    ``x_ideal = f·scale·(u, v) + pp``), or None when ``distortion`` is empty or all 0 (the pixels are ideal
    already). ``distortion``: ``(k1, k2, k3, p1, p2)`` (:class:`fotogeo.orientation.bundle.Block`'s) or a dict."""
    from ...orientation import bundle_jacobian as bj
    terms = list(coefficients(distortion if isinstance(distortion, dict) else tuple(distortion or ())))
    if not any(terms):
        return None
    interior = np.array([camera.focal_length, *camera.principal_point, *terms])
    scale = bj.pixel_scale(camera)

    def ideal(xy):
        uv = bj.undistort_rays(np.asarray(xy, dtype=np.float64).reshape(-1, 2), interior, scale)[:, :2]
        return uv * camera.focal_length * scale[:2] + np.asarray(camera.principal_point)
    return ideal


def _epipolar_inliers(xy1, xy2, threshold):
    import cv2
    if len(xy1) < 8:
        return np.zeros(len(xy1), bool)
    _, mask = cv2.findFundamentalMat(xy1.astype(np.float64), xy2.astype(np.float64), cv2.FM_RANSAC, threshold,
                                     0.999)
    return np.zeros(len(xy1), bool) if mask is None else mask.ravel().astype(bool)


#: fewest epipolar inliers that make a pair: a fundamental matrix fits any 7 matches exactly, and RANSAC over a
#: pair's few random matches finds 8–11 that fit one by chance. Measured against the truth on the rendered
#: 100-frame block (``benchmarks/triangulate_block_bench.py --strips 10 --per-strip 10``, 519 pairs): pairs of
#: 9–10 inliers 28 % right matches, 11–12 51 %, 13–15 73 %, 30 or more 98 %; from 12 up the pairs keep 99 % of
#: the right matches and lose 37 % of the wrong ones (:mod:`fotogeo.tools.triangulate.start` asks 12 too).
MIN_PAIR_INLIERS = 12


def epipolar_kept(xy_i, xy_j, ideal, threshold: float, min_inliers: int = MIN_PAIR_INLIERS):
    """``(matches, xy_i, xy_j)``: the number of matches and the measured pixels of those that fit the
    fundamental matrix within ``threshold`` px (RANSAC on ``ideal(xy)`` when ``ideal`` is given); none when
    fewer than ``min_inliers`` fit (a consensus chance gives, :data:`MIN_PAIR_INLIERS`)."""
    keep = _epipolar_inliers(*((xy_i, xy_j) if ideal is None else (ideal(xy_i), ideal(xy_j))), threshold)
    if keep.sum() < min_inliers:
        keep[:] = False
    return int(len(keep)), xy_i[keep], xy_j[keep]


class _Detected:
    """:func:`find_tie_points`' cache for a pair whose frames were detected by other tasks."""

    def __init__(self, reference, target):
        self.by_role = {"reference": reference, "target": target}

    def features(self, info, role, opts, prog):
        return self.by_role[role]


def frame_features(path: str, role: str, det):
    """The Dask task detecting one frame: ``(keypoints, factor, explained)`` as the in-process cache has them."""
    from ..common.dask_cluster import pin_threads
    pin_threads()
    return FeatureCache().features(open_raster(path, "frame"), role, det, as_progress(None))


def match_pair(path_i: str, path_j: str, features_i, features_j, det, threshold: float, camera, distortion):
    """The Dask task matching one pair: ``(kept, rematched)`` — :func:`epipolar_kept`'s ``(matches, xy_i, xy_j)``,
    or None when the descriptors do not match (:class:`MatchingError`), and the pair's ``bands_rematched`` report
    (:func:`fotogeo.tools.register.bands.rematch`; None when no re-match was tried), as the in-process path has them."""
    from ..common.dask_cluster import pin_threads
    pin_threads()
    try:
        xy_j, xy_i, counts = find_tie_points(open_raster(path_i, "frame"), open_raster(path_j, "frame"), det,
                                             cache=_Detected(features_i, features_j))
    except MatchingError:
        return None, None
    return epipolar_kept(xy_i, xy_j, ideal_pixels(camera, distortion), threshold), counts.get("bands_rematched")


def _detections(client, paths, pairs, det, run: str):
    """``({(frame, nodata override): future}, [(key of i, key of j), ...])``: one detection task per frame and
    nodata override, in the role of its first pair (as :class:`FeatureCache` keys and fills it); the second
    list names each pair's two detections."""
    futures, keys, which = {}, {}, []
    for i, j in pairs:
        pair_keys = []
        for f, role in ((i, "reference"), (j, "target")):
            key = (f, getattr(det, f"{role}_nodata"))
            if key not in keys:
                keys[key] = len(keys)
                futures[key] = client.submit(frame_features, str(paths[f]), role, det, pure=False,
                                             key=f"fotogeo-frame-{f}-{keys[key]}-{run}")
            pair_keys.append(key)
        which.append(tuple(pair_keys))
    return futures, which


@contextmanager
def dask_client(client=None, scheduler=None, workers=None):
    """The ``dask.distributed.Client`` the tasks run on — ``client``, one of the scheduler at ``scheduler`` or
    of a local cluster of ``workers`` processes (:func:`fotogeo.tools.common.dask_cluster.connect`, closed on exit) — or
    None when none is given (everything in this process)."""
    if client is None and not scheduler and not workers:
        yield None
        return
    from ..common.dask_cluster import connect
    c, close = connect(client, scheduler, workers, what="triangulate --workers")
    try:
        yield c
    finally:
        close()


def _gathered(futures: dict, prog, what: str) -> list:
    """The results of ``{future: index}`` in index order, as they complete; a cancel cancels the rest."""
    from ..common.dask_cluster import distributed_module
    distributed = distributed_module("triangulate --workers")
    results = [None] * len(futures)
    try:
        for n, fut in enumerate(distributed.as_completed(list(futures)), 1):
            results[futures[fut]] = fut.result()
            prog(n / len(results), f"{what} {n}/{len(results)} (Dask)")
        return results
    except (Cancelled, KeyboardInterrupt):
        for fut in futures:
            fut.cancel()
        raise
    finally:
        futures.clear()


def dask_pair_results(client, paths, pairs, det, threshold: float, camera, distortion, progress=None) -> list:
    """:func:`match_pair`'s ``(kept, rematched)`` of every pair (``kept`` None where the descriptors do not match),
    in pair order, computed as Dask tasks on ``client`` (module docstring)."""
    run = uuid.uuid4().hex[:8]
    features, which = _detections(client, paths, pairs, det, run)
    futures = {client.submit(match_pair, str(paths[i]), str(paths[j]), features[ki], features[kj], det, threshold,
                             camera, distortion, pure=False, key=f"fotogeo-pair-{i}-{j}-{run}"): k
               for k, ((i, j), (ki, kj)) in enumerate(zip(pairs, which))}
    features.clear()  # the scheduler keeps a frame's keypoints until its last pair has run
    return _gathered(futures, as_progress(progress), "matched pair")


def grey(info) -> np.ndarray:
    """The frame at full resolution as one float32 band (mean of the bands), NaN where nodata."""
    return _full(info)[1]


def _full(info) -> tuple:
    """``(bands (B, rows, cols), grey)`` of the frame at full resolution (:func:`grey`)."""
    bands, mask, _ = read_decimated(info, info.width * info.height + 1, "frame")
    img = bands.astype(np.float32).mean(axis=0)
    img[~mask] = np.nan
    return bands, img


def lsm_pair(info_a, info_b, grey_a, grey_b, anchors, xy, jacobian, half_window: int, max_shift: float,
             min_sigma: float, bands=(None, None)):
    """:func:`lsm_group` of one frame pair on the greys (given); when the frames' counts of data bands differ
    (:func:`mixed`), also on :func:`band_frames` (of the frames' full-resolution ``bands``, read here when None) in
    windows :data:`MIXED_WINDOW_SCALE` times wider — a trial, merged window by window (:func:`merged_windows`). When
    the combined bands do not correlate better than the greys, :func:`band_frames` returns the greys and the trial
    is least-squares matching of the greys in the wider windows, under the same merge: it adds only windows the
    narrow run did not converge on, and drops those where the two disagree."""
    plain = lsm_group(grey_a, grey_b, anchors, xy, jacobian, half_window, max_shift, min_sigma)
    if not mixed(info_a, info_b):
        return plain
    bands_a, bands_b = (_full(info)[0] if b is None else b for info, b in zip((info_a, info_b), bands))
    images = band_frames(bands_a[data_bands(info_a)], bands_b[data_bands(info_b)], grey_a, grey_b, anchors, xy,
                         half_window)
    wide = lsm_group(*images, anchors, xy, jacobian, int(round(MIXED_WINDOW_SCALE * half_window)), max_shift,
                     min_sigma)
    return merged_windows(plain, wide)


def mixed(info_a, info_b) -> bool:
    """Whether two frames hold other counts of data bands (:func:`data_bands`: an alpha band is a mask)."""
    return len(data_bands(info_a)) != len(data_bands(info_b))


def frame_read(info, keep_bands: bool) -> tuple:
    """``(bands or None, grey)`` of one read: :func:`grey` and, when ``keep_bands``, the bands it came from."""
    bands, img = _full(info)
    return (bands if keep_bands else None), img


def data_bands(info) -> list:
    """The 0-based indices of the frame's data bands (:attr:`fotogeo.io.raster.RasterInfo.data_bands`: no alpha)."""
    return list(info.data_bands or range(info.count))


#: a window converged both in the plain and in the wider trial run (:func:`merged_windows`) is dropped when the two
#: positions lie further apart than this (px): converged LSM fits of one window agree to a few tenths of a pixel
#: (their σ, floored by ``min_sigma``), and the 1.5x wider window adds a ring of the same local affinity, whose
#: relief changes the fit by well under a pixel; a wrong fit lands a texture period or an edge away
AGREE_PX = 1.0


def merged_windows(plain, wide, agree: float = AGREE_PX):
    """:func:`lsm_group` results ``(ok, xy, sigma)`` of the same windows merged: each window's plain fit when only
    it converged, the one of smaller σ when both converged within ``agree`` px of each other, and neither when they
    disagree (one of them is wrong, and nothing says which)."""
    n = len(plain[0])
    full = []
    for ok, got, sigma in (plain, wide):
        at, s = np.full((n, 2), np.nan), np.full(n, np.nan)
        at[ok], s[ok] = got, sigma
        full.append((np.asarray(ok, bool), at, s))
    (p_ok, p_xy, p_s), (w_ok, w_xy, w_s) = full
    apart = p_ok & w_ok & ~(np.hypot(*(p_xy - w_xy).T) <= agree)
    ok = (p_ok | w_ok) & ~apart
    take_wide = w_ok & ~(p_ok & (p_s <= w_s))
    return ok, np.where(take_wide[:, None], w_xy, p_xy)[ok], np.where(take_wide, w_s, p_s)[ok]


#: a pair of frames in other band sets: the multi-band frame's bands are combined to look like the other's grey
#: from the windows within this many window sizes of the ties (where the ties' homography holds)
NEAR_TIES = 3
#: ... and least-squares matched on them in windows this many times wider as a trial (:func:`lsm_pair`): what
#: correlates across band sets is the larger structure (fields, roads), which a narrow window holds little of
MIXED_WINDOW_SCALE = 1.5


def band_frames(bands_a, bands_b, grey_a, grey_b, anchors, xy, half_window: int):
    """``(image_a, image_b)`` least-squares matching reads: the frames' greys, or — when their band counts differ and
    one has several — that frame's bands combined by least squares to predict the other's grey
    (:func:`fotogeo.image.band_match.fit_combination`, fitted on images smoothed as the band re-match's rough fit,
    :data:`fotogeo.tools.register.bands.ROUGH_FIT_SMOOTHING`, near the ties, through the homography of the ties
    ``anchors`` (frame a) -> ``xy`` (frame b); one RANSAC) when it correlates better than the grey. A NIR-only frame
    against an RGB one: vegetation bright in one and dark in the mean of the other, which LSM's gain and offset do
    not model. ``bands_*`` (B, rows, cols)."""
    if len(bands_a) == len(bands_b) or max(len(bands_a), len(bands_b)) < 2 or len(anchors) < 8:
        return grey_a, grey_b
    from ...errors import FotogeoError
    from ...image.band_match import fit_combination
    from ...image.fusion import Fusion
    from ...models import Projective, ransac
    from ..register.bands import ROUGH_FIT_SMOOTHING
    a_side = len(bands_a) > len(bands_b)
    bands, grey, other, src, dst = ((bands_a, grey_a, grey_b, anchors, xy) if a_side else
                                    (bands_b, grey_b, grey_a, xy, anchors))
    try:
        H = ransac(Projective, np.asarray(src, float), np.asarray(dst, float), 2.0 * half_window,
                   rng=np.random.default_rng(0)).model
    except FotogeoError:
        return grey_a, grey_b
    near = np.zeros(grey.shape, np.uint8)
    r = NEAR_TIES * (2 * half_window + 1)
    for x, y in np.asarray(src, float):
        near[max(0, int(y) - r):int(y) + r + 1, max(0, int(x) - r):int(x) + r + 1] = 1
    blur = lambda im: cv2.GaussianBlur(np.nan_to_num(np.asarray(im, np.float32)), (0, 0),  # noqa: E731
                                       ROUGH_FIT_SMOOTHING)
    own_mask, other_mask = np.isfinite(grey), np.isfinite(other)
    inner = cv2.erode(own_mask.astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool) & near.astype(bool)
    fused = lambda im, m: Fusion(blur(im), m, np.ones(len(bands)), 1.0, (0.0, 255.0))  # noqa: E731
    comb = fit_combination(np.stack([blur(b) for b in bands]), inner, fused(grey, own_mask), H.forward,
                           replace(fused(other, other_mask), component=np.ones(1)))
    if comb is None or not comb.better:
        return grey_a, grey_b
    img = (np.tensordot(comb.weights, bands.astype(np.float32), axes=1) + comb.offset).astype(np.float32)
    img[~own_mask] = np.nan
    return (img, grey_b) if a_side else (grey_a, img)


def lsm_group(image_a, image_b, anchors, xy, jacobian, half_window: int, max_shift: float, min_sigma: float):
    """``(ok (n,), xy (k, 2), sigma (k,))``: least-squares matching of the ``anchors`` windows of frame a into
    frame b from ``xy`` and the local affinity ``jacobian`` (:func:`fotogeo.matching.lsm_many`); the refined
    pixels and σ ``= max(sqrt((σx² + σy²) / 2), min_sigma)`` of the ``k`` that converged."""
    from ...matching import lsm_many
    res = lsm_many(image_a, image_b, anchors, xy, half_window=half_window, approx_jacobian=jacobian,
                   max_shift=max_shift)
    good = res.ok
    return good, res.xy[good], np.maximum(np.sqrt(np.mean(res.sigma[good] ** 2, axis=1)), min_sigma)


def lsm_task(path_a: str, path_b: str, anchors, xy, jacobian, half_window: int, max_shift: float,
             min_sigma: float):
    """The Dask task of :func:`lsm_group` on two frames read from their paths."""
    from ..common.dask_cluster import pin_threads
    pin_threads()
    info_a, info_b = open_raster(path_a, "frame"), open_raster(path_b, "frame")
    (b_a, g_a), (b_b, g_b) = (frame_read(info, mixed(info_a, info_b)) for info in (info_a, info_b))
    return lsm_pair(info_a, info_b, g_a, g_b, anchors, xy, jacobian, half_window, max_shift, min_sigma, (b_a, b_b))


def dask_lsm_results(client, paths, groups, half_window: int, max_shift: float, min_sigma: float,
                     progress=None) -> list:
    """:func:`lsm_group` of every ``(frame a, frame b, anchors, xy, jacobian)`` of ``groups``, in order, as
    Dask tasks on ``client``."""
    run = uuid.uuid4().hex[:8]
    futures = {client.submit(lsm_task, str(paths[fa]), str(paths[fb]), anchors, xy, jac, half_window, max_shift,
                             min_sigma, pure=False, key=f"fotogeo-lsm-{fa}-{fb}-{run}"): k
               for k, (fa, fb, anchors, xy, jac) in enumerate(groups)}
    return _gathered(futures, as_progress(progress), "least-squares matching")


def local_affinity(camera, eo_from, eo_to, xy, height: float) -> np.ndarray:
    """``(n, 2, 2)`` Jacobians ``J[:, :, k] = ∂x_to / ∂(axis k of x_from)`` of the transfer of frame pixels
    ``xy`` through the plane at ``height`` with the approximate orientations (identity where undefined)."""
    a, b = OrientedFrame(camera, eo_from), OrientedFrame(camera, eo_to)

    def transfer(p):
        return b.world_to_pixel(a.pixel_to_world_at(p, height))
    e = 0.5
    jx = (transfer(xy + [e, 0]) - transfer(xy - [e, 0])) / (2 * e)
    jy = (transfer(xy + [0, e]) - transfer(xy - [0, e])) / (2 * e)
    J = np.stack([jx, jy], axis=2)
    bad = ~np.isfinite(J).all(axis=(1, 2))
    J[bad] = np.eye(2)
    return J


def refine_tracks(infos, frame, track, pixel, camera, eos, height, *, max_shift: float, half_window: int = 10,
                  min_sigma: float = 0.1, client=None, prog=None):
    """LSM transfer of each track's anchor window into its other frames (module docstring), frame pair by
    frame pair (at most two full-resolution frames in memory); with a Dask ``client``, one task per frame
    pair (:func:`fotogeo.tools.triangulate.pairs.dask_lsm_results`; the same results).

    Returns ``(keep (n,) bool, pixel (n, 2), sigma (n,), summary)``.
    """
    prog = as_progress(prog)
    n = len(frame)
    track = np.unique(track, return_inverse=True)[1].ravel()  # 0 .. T-1
    order = np.lexsort((frame, track))
    is_anchor = np.zeros(n, bool)
    is_anchor[order[np.r_[True, np.diff(track[order]) != 0]]] = True
    anchor_of = np.empty(int(track.max()) + 1 if n else 0, np.intp)
    anchor_of[track[is_anchor]] = np.flatnonzero(is_anchor)
    anchor = anchor_of[track]
    out, sigma, ok = pixel.copy(), np.full(n, np.nan), is_anchor.copy()
    others = np.flatnonzero(~is_anchor)
    key = frame[anchor[others]].astype(np.int64) * len(eos) + frame[others]
    others = others[np.argsort(key, kind="stable")]
    groups = np.split(others, np.flatnonzero(np.diff(np.sort(key))) + 1) if len(others) else []
    jobs = [(int(frame[anchor[m[0]]]), int(frame[m[0]]), pixel[anchor[m]], pixel[m]) for m in groups]
    jobs = [(fa, fb, a, xy, local_affinity(camera, eos[fa], eos[fb], a, height)) for fa, fb, a, xy in jobs]
    found = (_local_lsm(infos, jobs, half_window, max_shift, min_sigma, prog) if client is None else
             dask_lsm_results(client, [info.path for info in infos], jobs, half_window, max_shift, min_sigma, prog))
    for m, (good, xy, s) in zip(groups, found):
        out[m[good]], sigma[m[good]], ok[m[good]] = xy, s, True
    transfers = ok & ~is_anchor
    n_ok = np.bincount(track[transfers], minlength=len(anchor_of))
    ok &= n_ok[track] >= 1  # the anchor and at least one transfer
    s2 = np.bincount(track[transfers], weights=sigma[transfers] ** 2, minlength=len(anchor_of))
    has = n_ok >= 1  # the anchor: the RMS σ of its track's transfers
    sigma[anchor_of[has]] = np.sqrt(s2[has] / n_ok[has])
    moved = np.hypot(*(out[transfers] - pixel[transfers]).T)
    summary = {"transfers": int((~is_anchor).sum()), "converged": int(transfers.sum()),
               "median_shift_px": float(np.median(moved)) if len(moved) else None,
               "median_sigma_px": float(np.median(sigma[transfers])) if transfers.any() else None,
               "observations_dropped": int(n - ok.sum())}
    return ok, out, sigma, summary


def _local_lsm(infos, jobs, half_window, max_shift, min_sigma, prog):
    """:func:`lsm_pair` of each job in turn, in this process (the anchor frame stays in memory while its jobs run):
    at most two frames held, each read once while held — its grey and, in a mixed pair (:func:`mixed`), its bands."""
    with_bands = {f for fa, fb, *_ in jobs if mixed(infos[fa], infos[fb]) for f in (fa, fb)}
    cache: dict = {}
    for g, (fa, fb, anchors, xy, jac) in enumerate(jobs):
        prog(g / len(jobs), f"least-squares matching {g + 1}/{len(jobs)}")
        cache = {k: v for k, v in cache.items() if k in (fa, fb)}
        for f in (fa, fb):
            if f not in cache:
                cache[f] = frame_read(infos[f], f in with_bands)
        yield lsm_pair(infos[fa], infos[fb], cache[fa][1], cache[fb][1], anchors, xy, jac, half_window, max_shift,
                       min_sigma, (cache[fa][0], cache[fb][0]))
