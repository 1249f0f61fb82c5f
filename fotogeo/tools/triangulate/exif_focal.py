"""A camera guessed from EXIF ``FocalLength × FocalPlaneXResolution`` checked against the adjustment's residuals.

``FocalPlaneXResolution`` (pixels per millimetre on the sensor) is written for the camera's full-resolution frame;
:mod:`fotogeo.io.exif_camera` scales it to a resized file by ``width / PixelXDimension``. A tool that rewrites
``PixelXDimension``/``PixelYDimension`` to the new size (Photoshop/Lightroom exports) leaves it describing the full
frame, so the focal length in pixels comes out ``1/s`` times too long; a camera that writes no
``FocalLengthIn35mmFilm`` (the senseFly eBee's Canon IXUS 125 HS) leaves only the other records of the size the camera
wrote to contradict it (:mod:`fotogeo.io.exif_sizes`, checked when the file is read); this check is what is left
when the resizing tool rewrote or dropped those too.

The focal length cannot be told from the flying height in a near-nadir block over gentle terrain (its multiple
correlation exceeds ``--max-correlation``, so the self-calibration holds it fixed), so the adjustment bends the other
unknowns to fit and the tie points' residuals grow. Least-squares matching gives each tie point a formal σ (Grün 1985,
from the LSM normal equations); the image group's a-posteriori σ₀ with those σ (before the image variance component
rescales them, :func:`fotogeo.orientation.bundle._image_variance`) is how many times the residuals exceed the matcher's
precision: a few with the right camera, several times more with a focal length twice too long
(docs/benchmarks/dsm.md, "eBee flight", has the values measured by ``benchmarks/resized_frames_bench.py`` and the
command). Above :data:`MAX_IMAGE_SIGMA0` with such a camera the run is refused, naming the camera's source, the
sensor width it implies (``PixelXDimension / FocalPlaneXResolution``) and the fix; ``--self-calibration`` given
explicitly (``none`` included) takes the camera as the user's and skips the check.

A focal length edited to another value inside the lens's range (an editor, or a tag copied from another zoom
position) leaves the residuals within that threshold when the edit is small, and nothing in the files tells it from
a zoom position (:mod:`fotogeo.io.exif_lens`). The adjustment itself does: the self-calibration frees the focal
length and holds it fixed only when the block cannot tell it from the exterior orientation to the image σ
(:mod:`fotogeo.orientation.bundle_rules`); that rule keeps the estimate it had while free and its σ, and a block
tied to its frames' GNSS positions determines that estimate far too loosely to replace the camera (its σ moves the
image corners by more than the image σ) but well enough to contradict a value several hundredths off (the figures:
docs/benchmarks/dsm.md, "A focal length edited inside the zoom range").
:func:`check_exif_focal` warns when a camera from the images has a focal length that differs from that estimate
by more than :data:`FOCAL_SIGMAS` of its σ and :data:`FOCAL_SHARE` of the focal length (the second spares a lens
whose true focal length departs from its nominal one), naming both values and the ways out, and refuses it beyond
:data:`FOCAL_REFUSE_SHARE`. Between the two it is a warning, not a refusal: on a rendered nadir block whose 35 mm
equivalent gave exactly the true focal length, that nearly singular estimate (multiple correlation 0.9999, mostly
with k2) came out 16 % and 16 σ away on one seed of four — the estimate can contradict a right camera by that much,
while a focal length a quarter off moves the tie points' rays further than any seed did.
The estimate is not used instead: held fixed, the focal length failed the rule that a self-calibrated camera must
meet, and started from a focal length twice too long the free adjustment can stop halfway.

σ₀ alone does not tell a wrong focal length from an unmodelled lens. A pair adjusts with the camera held fixed (two
frames are too few to calibrate it, :meth:`~fotogeo.tools.triangulate.sources.BlockStart.interior_to_estimate`), so
its residuals carry the lens distortion, which shrinks in pixels with the image: the eBee pair IMG_2280/2281 gave
σ₀ 6.3 at full size with the right camera and 2.4 as a 1/4 copy with a focal length four times too long. Nor can a
pair tell the focal length: two near-nadir frames related by a translation along the strip see ``x = f·X/Z`` and the
parallax ``f·B/Z`` unchanged when ``f`` and the depths ``Z`` scale together (the normal case of a stereo pair), so
re-adjusted with ``f/2 … f/4`` that pair's σ₀ moved by at most a third. So the focal hypothesis is tested directly
(:func:`focal_hypotheses`): when σ₀ exceeds :data:`MAX_IMAGE_SIGMA0`, or the block estimated no interior parameter
(σ₀ then says nothing of the focal length), the adjustment is run again with the focal length divided by each
resize factor :data:`RESIZE_FACTORS` that leaves a plausible full frame (at most :data:`MAX_FULL_WIDTH` px wide).
The camera is refused only when one of them fits :data:`CLEARLY` times better (σ₀ at least that many times lower);
it passes when it fits that much better than all of them; between the two the block cannot tell, and a warning
names the hypothesis and the fix instead (the figures: docs/benchmarks/dsm.md, "A pair cannot check the focal
length"). On the eBee triple IMG_2280–2282 the rewritten 1/2 copy gave σ₀ 6.0 with its EXIF focal length and 1.4
with half of it; the full-size triple 2.5, and 4.5 with half.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ...errors import FotogeoError, FotogeoWarning, ModelError
from ...orientation.bundle import adjust_block

#: the image group's σ₀ with least-squares matching's formal σ above which a camera from FocalPlaneXResolution
#: is refused: between what the right camera and a focal length twice too long give (module docstring)
MAX_IMAGE_SIGMA0 = 4.0
FOCAL_PLANE = "FocalPlaneXResolution"
#: a focal length from the images is refused when the self-calibration's estimate held fixed is further from it than
#: this many of its σ …
FOCAL_SIGMAS = 3.0
#: … and than this share of it: a warning (module docstring)
FOCAL_SHARE = 0.05
#: … and a refusal beyond this share
FOCAL_REFUSE_SHARE = 0.25
#: the resize factors whose focal length ``f / k`` the block is adjusted again with (module docstring)
RESIZE_FACTORS = (2, 3, 4)
#: the widest full frame a factor may imply, px (a 150 MP medium-format back is 14204 px wide)
MAX_FULL_WIDTH = 15000
#: how many times lower one hypothesis's σ₀ must be than the other's for the block to tell them apart
CLEARLY = 2.0


def image_sigma0_given(stats: dict) -> float | None:
    """The image group's σ₀ with the σ the matcher gave (before any variance component), None if unknown."""
    image = (stats.get("variance_components") or {}).get("image") or {}
    s0 = image.get("sigma0_given", image.get("sigma0"))
    return float(s0) if s0 is not None and np.isfinite(s0) else None


def free_focal(fixed) -> tuple | None:
    """``(estimate, σ)`` in px of the focal length the correlation rule held fixed (its estimate while free,
    :func:`fotogeo.orientation.bundle_rules.correlation_rule`), None when it was not held so or its σ is unknown."""
    for entry in fixed or ():
        if entry.get("parameter") == "f" and "estimate" in entry and np.isfinite(entry.get("sigma", np.nan)):
            return float(entry["estimate"]), float(entry["sigma"])
    return None


def focal_hypotheses(block, opts) -> dict:
    """``{k: σ₀}``: the image group's σ₀ (:func:`image_sigma0_given`) of ``block`` adjusted again with ``opts`` and
    its camera's focal length divided by each of :data:`RESIZE_FACTORS` whose full frame ``k·width`` is at most
    :data:`MAX_FULL_WIDTH` px; ``inf`` where that adjustment fails (it does not fit at all), NaN where it gives no σ₀."""
    out = {}
    for k in RESIZE_FACTORS:
        if k * block.camera.image_size[0] > MAX_FULL_WIDTH:
            continue
        camera = dataclasses.replace(block.camera, focal_length=block.camera.focal_length / k)
        with warnings.catch_warnings():  # a hypothesis's own warnings are not the run's
            warnings.simplefilter("ignore")
            try:
                s0 = image_sigma0_given(adjust_block(dataclasses.replace(block, camera=camera), opts).stats)
            except FotogeoError:
                s0 = np.inf
        out[k] = np.nan if s0 is None else s0
    return out


def check_exif_focal(camera_source: str, camera, stats: dict, given: bool, fixed=(), *, refit=None,
                     lens_modelled: bool = True) -> None:
    """Refuse (:class:`ModelError`) a camera whose focal length comes from EXIF ``FocalPlaneXResolution`` when the
    tie points' residuals are more than :data:`MAX_IMAGE_SIGMA0` times the matcher's precision and, where ``refit``
    is given, the focal length divided by a resize factor fits :data:`CLEARLY` better (a warning where the block
    cannot tell); and a camera from the images whose focal length the self-calibration's estimate held fixed
    contradicts (module docstring). ``camera_source``: how the focal length was read
    (:func:`fotogeo.io.exif_camera.focal_of`'s source, "" for a camera file); ``given``: ``--self-calibration`` was
    given; ``fixed``: the adjustment's parameters held fixed; ``refit``: ``() -> {k: σ₀}`` (:func:`focal_hypotheses`
    of the block); ``lens_modelled``: the adjustment estimated interior parameters (else σ₀ carries the lens)."""
    if given or not camera_source:
        return
    w, h = camera.image_size
    px = w / camera.sensor_size[0]  # the camera's focal-length unit in pixels
    f, free = camera.focal_length * px, free_focal(fixed)
    mm = _focal_mm(camera_source)
    free = None if free is None else (free[0] * px, free[1] * px)
    estimate = "" if free is None else (f"; with the focal length free the adjustment puts it at {free[0]:.0f} ± "
                                        f"{free[1]:.0f} px" + (f" ({free[0] * mm / f:.2f} mm)" if mm else ""))
    s0 = image_sigma0_given(stats)
    if FOCAL_PLANE in camera_source and s0 is not None and (s0 > MAX_IMAGE_SIGMA0 or not lens_modelled):
        _check_focal_plane(camera_source, (w, h), f, mm, s0, estimate, stats, refit, lens_modelled)
    if free is None or abs(free[0] - f) <= max(FOCAL_SIGMAS * free[1], FOCAL_SHARE * f):
        return
    share = abs(free[0] / f - 1)
    text = (f"the images' focal length is {f:.0f} px from {camera_source.split(';')[0]}{estimate}, {share:.0%} and "
            f"{abs(free[0] - f) / free[1]:.0f} σ from it (more than {FOCAL_SHARE:.0%} and {FOCAL_SIGMAS:g} σ): the "
            f"focal length tag may be edited, a rounded nominal value or another lens's or zoom position's (the "
            f"camera's original files keep the one it took them with)")
    if share <= FOCAL_REFUSE_SHARE:
        text += ("; the results use the images' focal length: check them against control, give the camera "
                 "(--camera), or let the adjustment estimate it (--self-calibration f,k1,k2,p1,p2 --max-correlation 1)")
        _warn(stats, text)
        return
    raise ModelError(text + f"; more than {FOCAL_REFUSE_SHARE:.0%} off: give the camera (--camera), or, if the "
                     f"images' focal length is right, --self-calibration none", option="--camera")


def _check_focal_plane(source, size, f, mm, s0, estimate, stats, refit, lens_modelled) -> None:
    """The residual check of a focal length from ``FocalPlaneXResolution`` (:func:`check_exif_focal`): refuse,
    warn (the block cannot tell) or pass on the hypotheses ``refit`` gives (refuse on σ₀ alone without it)."""
    hyp = {} if refit is None else refit()
    if hyp:
        stats["focal_hypotheses"] = {str(k): round(float(v), 2) if np.isfinite(v) else None  # report.json's statistics
                                     for k, v in {1: s0, **hyp}.items()}
    else:  # no hypothesis to test: σ₀ alone, where it measures the focal length
        refit = None
        if s0 <= MAX_IMAGE_SIGMA0:
            return
    best = min(hyp, key=lambda k: hyp[k] if np.isfinite(hyp[k]) else np.inf, default=None)
    fitted = best is not None and hyp[best] * CLEARLY < s0
    if refit is not None and not fitted and all(s0 * CLEARLY < v for v in hyp.values() if not np.isnan(v)):
        return  # the block confirms the focal length: its residuals have another cause
    w, h = size
    sensor = f" and a sensor {w * mm / f:.2f} x {h * mm / f:.2f} mm" if mm else ""
    why = (f"the tie points' residuals are {s0:.1f} times least-squares matching's precision"
           + (f" (more than {MAX_IMAGE_SIGMA0:g})" if s0 > MAX_IMAGE_SIGMA0 else "")
           + f" with the camera guessed from the images' EXIF: focal {f:.0f} px at {w}x{h} px from {source}{sensor}"
           + estimate + "".join(f", {v:.1f} with focal {f / k:.0f} px (1/{k})" for k, v in hyp.items()))
    cause = ("FocalPlaneXResolution describes the camera's full frame, so a copy resized with its EXIF PixelXDimension "
             "rewritten to the new size gets a focal length too long by the resize factor (and an edited FocalLength "
             "tag by any factor)")
    if refit is None or fitted:
        raise ModelError(f"{why}; {cause}; give the camera (--camera), triangulate the originals, or, if the camera is "
                         f"right, --self-calibration none (or the parameters to estimate)", option="--camera")
    lens = ("; the camera held fixed (too few frames to calibrate it), the residuals also carry its lens distortion"
            if not lens_modelled else "")
    _warn(stats, f"{why}: the block cannot tell a wrong focal length from other causes (not {CLEARLY:g} times apart)"
                 f"{lens}; {cause}: if these images are such a copy, give the camera (--camera) or triangulate the "
                 f"originals; more frames (3 or more, across strips) let the adjustment check it")


def _warn(stats: dict, text: str) -> None:
    """Warn ``text`` and keep it in ``stats["focal_length_check"]`` (report.json's statistics; the command line
    prints it even with -q)."""
    stats["focal_length_check"] = "; ".join(filter(None, [stats.get("focal_length_check"), text]))
    warnings.warn(text, FotogeoWarning, stacklevel=3)


def _focal_mm(source: str) -> float | None:
    """The focal length in mm at the start of a ``"4.3 mm x FocalPlaneXResolution (…)"`` source."""
    head = source.split(" mm x ", 1)[0]
    try:
        return float(head)
    except ValueError:
        return None
