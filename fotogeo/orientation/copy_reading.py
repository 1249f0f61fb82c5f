"""Whether GCP pixel positions were read on another copy of the image: one of another size or turned a quarter turn.

A copy ``s`` times the image's size (a resize, whatever tool wrote it) scales every pixel position about the corner
``(0, 0)``: the position read on the copy is ``s · (col, row)`` of this image (corner convention,
:mod:`fotogeo.pixels`). A copy turned clockwise by a quarter turn is ``height`` x ``width``; its position
``(c', r')`` is ``(r', height − c')`` of this image; turned by a half turn ``(width − c', height − r')``, by three
quarters ``(width − r', c')``.

A model with a free scale (affine, projective, polynomial, rational) absorbs a copy's scaling exactly: only which
points fall inside changes, and a top-left crop of the frame the GCPs were measured on looks the same. A model whose
interior is fixed — the collinearity equations with a camera's focal length and principal point in pixels — cannot:
positions read on a copy leave residuals far above the click precision, which the same fit of the positions read
back into this image (``/ s``, or turned back) does not. The rule (:func:`copy_reading`): when the least-squares fit
of the control points inside the image leaves an RMS above :data:`EXPLAINED` times the image σ, every candidate
reading is fitted to its own control points inside the image (at least as many as the positions as given keep), and
the best one is named when it leaves :data:`BETTER` times less, or :data:`BETTER_EXPLAINED` times less when the
click precision explains it (RMS at most :data:`EXPLAINED` times σ: a copy read back with a good camera, which a
camera that leaves the right positions unexplained — a focal length 20 % off — does not imitate: its best reading
leaves about as much as as given). Both RMS are compared in the given positions' pixels: reading back ``/ s`` divides any residual the fit leaves (an unmodelled distortion, a focal length 20 % off)
by ``s`` too, so the read-back RMS counts ``s`` times (:func:`_read_back_rms`); otherwise a poor camera's misfit,
shrunk four times, would name a copy 4x the size. The factors tried stay inside :data:`SCALES`: a coarse set first
(:func:`_coarse_scales`), then the best refined within one coarse step (:func:`_refine`); a reading that leaves
fewer control points inside than the positions as given is not fitted. A crop whose camera describes it (principal point
where the frame's falls in the crop's pixels) fits as given and is left alone; so is a half turn about a central
principal point, which the collinearity equations absorb (a rotation about the optical axis). A fit that fails or
leaves a non-finite RMS (no heights, a projection out of its domain) tells nothing: no reading is named.

Over flat terrain the collinearity equations trade a copy's scale for the flying height, so positions read on a
copy ``s`` times the size fit as given as well as a crop's do. Whether the GCPs fitting as given are a crop's is
therefore confirmed only when the positions read back at the size their spread implies fit worse than
:data:`EXPLAINED` times the image σ (:func:`crop_reading`); when both fit, the two cannot be told apart.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import FotogeoError
from ..image_extent import on_image
from ..models import get_model
from .adjustment import fit_data, image_residuals

#: the click precision (px) assumed for a GCP's image position when none is given
CLICK_SIGMA_PX = 0.5
#: a fit's RMS (px) above this many times the image σ asks whether the positions were read on another copy
EXPLAINED = 3.0
#: a reading is named when its fit leaves at least this many times less RMS than the positions as given
BETTER = 5.0
#: a reading whose fit the click precision explains (RMS ≤ EXPLAINED · σ) is named when it leaves this many times less
BETTER_EXPLAINED = 2.0
#: the copies' sizes tried, as factors of this image's size (about 3 % apart), then refined around the best
SCALES = np.exp(np.linspace(math.log(0.25), math.log(4.0), 97))
#: the scales fitted first are every COARSE-th of SCALES (about 12 % apart); the best is then refined
COARSE = 4
#: factors this close to 1 are not a copy of another size (a fit's own scale error)
NEAR_ONE = 0.04
#: turns of a copy, clockwise, in quarter turns
TURNS = (1, 2, 3)
#: readings whose fits leave RMS within this factor of the best are not told apart
TIE = 1.1


def read_back(pixel, width: int, height: int, scale: float = 1.0, turns: int = 0) -> np.ndarray:
    """Positions ``pixel`` read on a copy ``scale`` times this image's size and turned ``turns`` quarter turns
    clockwise, as positions on this ``width`` x ``height`` image (module docstring)."""
    p = np.asarray(pixel, float).reshape(-1, 2) / scale
    c, r = p[:, 0], p[:, 1]
    return {0: p, 1: np.column_stack([r, height - c]), 2: np.column_stack([width - c, height - r]),
            3: np.column_stack([width - r, c])}[turns % 4]


def collinearity_rms(camera, distortion=None):
    """``rms(ground, pixel)``: the RMS (px) of the residual vectors of the collinearity resection with ``camera``
    fitted to all the points by least squares; ``inf`` where it fails. ``distortion``: Brown's ``(k1, k2, k3, p1,
    p2)`` of the camera (a block's), removed from the pixels first (:func:`_pinhole`); None or zeros: none."""
    cls = get_model("collinearity")

    def rms(ground, pixel) -> float:
        try:
            pixel = _pinhole(camera, distortion, np.asarray(pixel, float))
            src, dst = fit_data(cls, ground, pixel)
            model = cls.estimate(src, dst, camera=camera)
            res = image_residuals(model, ground, pixel)
        except (FotogeoError, ValueError, np.linalg.LinAlgError, FloatingPointError):
            return math.inf
        value = float(np.sqrt(np.mean(np.sum(res ** 2, axis=1))))
        return value if math.isfinite(value) else math.inf
    return rms


def _pinhole(camera, distortion, pixel) -> np.ndarray:
    """``pixel`` as a distortion-free camera would see it: ``K·(u, v, 1)`` of the undistorted rays
    (:func:`fotogeo.orientation.bundle_jacobian.undistort_rays`); ``pixel`` itself without distortion."""
    if distortion is None or not np.any(np.asarray(distortion, float)):
        return pixel
    from . import bundle_jacobian as bj
    interior = np.array([camera.focal_length, *camera.principal_point, *distortion], dtype=np.float64)
    return bj.undistort_rays(pixel, interior, bj.pixel_scale(camera)) @ camera.K[:2].T


def copy_reading(ground, pixel, control, width: int, height: int, fit_rms, sigma: float, min_points: int):
    """``None`` when the control points' positions fit as given (or too few lie inside to tell), else
    ``{"scale", "turns", "rms_given", "rms_read_back", "n_given", "n_read_back"}``: the reading of the positions
    (:func:`read_back`) that explains them :data:`BETTER` times better, or :data:`BETTER_EXPLAINED` times and within
    :data:`EXPLAINED` · ``sigma`` (module docstring; RMS compared in the given positions' pixels). ``fit_rms(ground,
    pixel)`` fits the model; ``sigma``: the image σ (px) of the positions; ``min_points``: the model's minimum."""
    ground, pixel, control = np.asarray(ground, float), np.asarray(pixel, float), np.asarray(control, bool)
    rms_given, n_given = _fitted(ground, pixel, control, width, height, fit_rms)
    if n_given < min_points + 2 or not math.isfinite(rms_given) or rms_given <= EXPLAINED * sigma:
        return None

    def trial(scale, turns):
        """The reading's RMS in the given positions' pixels (:func:`_read_back_rms`), and its points inside."""
        rms, n = _fitted(ground, read_back(pixel, width, height, scale, turns), control, width, height, fit_rms,
                         least=n_given)
        return _read_back_rms(rms, scale), n

    readings = [(s, 0) for s in _coarse_scales()] + [(1.0, t) for t in TURNS]
    readings += [(s, t) for s in SCALES[::8] for t in TURNS if abs(math.log(s)) > NEAR_ONE]
    scored = [(trial(s, t)[0], s, t) for s, t in readings]
    least = min(r for r, _, _ in scored)
    # readings the collinearity equations cannot tell apart (a half turn about a central principal point): the one
    # with the fewest turns, a quarter turn either way when its opposite fits as well
    _, turns, _, scale = min((t == 2, t, r, s) for r, s, t in scored if r <= TIE * least)
    either = turns % 2 == 1 and any(t == (turns + 2) % 4 and r <= TIE * least for r, _, t in scored)
    if scale != 1.0:
        scale = _refine(lambda s: trial(s, turns)[0], scale, COARSE * math.log(SCALES[1] / SCALES[0]), within=SCALES)
    rms, n = _fitted(ground, read_back(pixel, width, height, scale, turns), control, width, height, fit_rms,
                     least=n_given)
    left = _read_back_rms(rms, scale)
    explained = left <= EXPLAINED * sigma and not _focal_explains(ground, pixel, control, width, height, fit_rms,
                                                                   sigma, scale, turns, n_given)
    if not rms_given >= (BETTER_EXPLAINED if explained else BETTER) * left:
        return None
    return {"scale": round(scale, 2), "turns": turns, "either_way": either, "rms_given": rms_given,
            "rms_read_back": rms, "n_given": n_given, "n_read_back": n}


def _focal_explains(ground, pixel, control, width, height, fit_rms, sigma, scale, turns, least) -> bool:
    """Whether a focal length ``1 / scale`` times the camera's explains the positions as well as a copy ``scale``
    times the size: the positions scaled by ``1 / scale`` about the image's centre (where a principal point lies)
    instead of its corner fit within :data:`EXPLAINED` · ``sigma``. A focal length off by ``k`` scales the image
    about the principal point; a copy about the corner: the two differ by a shift the resection absorbs by a
    rotation, the better the narrower the field of view (a 5° frame with a focal 20 % short reads as a copy 1.2x the
    size), and then only :data:`BETTER` names a copy."""
    if turns or scale == 1.0:
        return False
    centre = np.array([width, height], float) / 2.0
    about_centre = centre + (np.asarray(pixel, float) - centre) / scale
    rms = _fitted(ground, about_centre, control, width, height, fit_rms, least=least)[0]
    return _read_back_rms(rms, scale) <= EXPLAINED * sigma


def _coarse_scales() -> list:
    """The factors of :data:`SCALES` fitted first: every :data:`COARSE`-th, and the two nearest 1 beyond
    :data:`NEAR_ONE`, so that a copy's factor lies within half a coarse step of one of them and nearer to it than to
    1 (its refinement, one coarse step either way, then reaches it)."""
    far = [s for s in SCALES if abs(math.log(s)) > NEAR_ONE]
    near = [max(s for s in far if s < 1.0), min(s for s in far if s > 1.0)]
    return sorted({float(s) for s in SCALES[::COARSE] if abs(math.log(s)) > NEAR_ONE} | set(near))


def _read_back_rms(rms: float, scale: float) -> float:
    """The RMS ``rms`` (px of this image) of positions read back ``/ scale``, in the given positions' pixels:
    ``rms · scale`` (``inf`` when not finite), the units of the positions as given."""
    return rms * scale if math.isfinite(rms) else math.inf


def crop_reading(ground, pixel, control, width: int, height: int, fit_rms, sigma: float, min_points: int,
                 scale: float):
    """Whether GCPs most of which lie outside, spanning about ``scale`` times this image's size, are a crop's
    (module docstring): ``{"reading", "scale", "rms_given", "n_given", "rms_read_back", "n_read_back"}``;
    ``reading`` is ``"crop"`` when the control points inside fit as given within :data:`EXPLAINED` times ``sigma``
    and the positions read back at the best factor near ``scale`` (:func:`read_back`) do not, ``"either"`` when both
    fit (the two cannot be told apart), ``None`` otherwise (too few points inside, a fit not finite, neither fits)."""
    ground, pixel, control = np.asarray(ground, float), np.asarray(pixel, float), np.asarray(control, bool)

    def back(s):
        rms = _fitted(ground, read_back(pixel, width, height, s), control, width, height, fit_rms)[0]
        return rms if math.isfinite(rms) else math.inf
    rms_given, n_given = _fitted(ground, pixel, control, width, height, fit_rms)
    scale = _refine(back, scale)
    rms_back, n_back = _fitted(ground, read_back(pixel, width, height, scale), control, width, height, fit_rms)
    fits_given = n_given >= min_points + 2 and rms_given <= EXPLAINED * sigma
    fits_back = n_back >= min_points + 2 and rms_back <= EXPLAINED * sigma
    finite = math.isfinite(rms_given) and math.isfinite(rms_back)
    reading = ("either" if fits_back else "crop") if fits_given and finite else None
    return {"reading": reading, "scale": round(scale, 2), "rms_given": rms_given, "n_given": n_given,
            "rms_read_back": rms_back, "n_read_back": n_back}


def _fitted(ground, pixel, control, width: int, height: int, fit_rms, least: int = 0) -> tuple[float, int]:
    """``(rms, n)``: ``fit_rms`` of the ``n`` control points whose ``pixel`` lies on the image
    (:func:`fotogeo.image_extent.on_image`, the rule that skips GCPs outside; ``nan`` for none); ``inf``, not
    fitted, when fewer than ``least`` lie inside."""
    keep = control & on_image(pixel[:, 0], pixel[:, 1], width, height)
    n = int(keep.sum())
    if n < least:
        return math.inf, n
    return (float(fit_rms(ground[keep], pixel[keep])) if n else math.nan), n


def _refine(cost, scale: float, step: float | None = None, within=None, steps: int = 16) -> float:
    """The factor near ``scale`` (within ``step`` of its logarithm, one step of :data:`SCALES` by default; inside
    the range of the factors ``within`` when given) where ``cost`` is least: golden-section search on its
    logarithm."""
    step = math.log(SCALES[1] / SCALES[0]) if step is None else step
    a, b = math.log(scale) - step, math.log(scale) + step
    if within is not None:
        a, b = max(a, math.log(min(within))), min(b, math.log(max(within)))
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - g * (b - a), a + g * (b - a)
    f1, f2 = cost(math.exp(x1)), cost(math.exp(x2))
    for _ in range(steps):
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - g * (b - a)
            f1 = cost(math.exp(x1))
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + g * (b - a)
            f2 = cost(math.exp(x2))
    return math.exp((a + b) / 2.0)


def describe(found: dict) -> str:
    """The reading ``found`` (:func:`copy_reading`) in words: which copy and how to bring the positions back."""
    s, t = found["scale"], found["turns"]
    turned = {1: "turned 90° clockwise", 2: "turned 180°", 3: "turned 90° counter-clockwise"}.get(t)
    if found.get("either_way"):
        turned = "turned a quarter turn"
    size = f"a copy about {s:g}x this image's size" if s != 1.0 else "a copy of this image"
    copy = " ".join(filter(None, (size, turned)))
    fix = " and ".join(filter(None, (f"rescale them (col/row ÷ {s:g})" if s != 1.0 else "",
                                     "turn them back" if turned else "")))
    return (f"the GCP pixels look measured on {copy}: read back onto this image, {found['n_read_back']} control "
            f"points fit with {found['rms_read_back']:.2f} px RMS, as given {found['n_given']} inside fit with "
            f"{found['rms_given']:.2f} px; measure them on this file or {fix}")


def describe_undecided(told: dict, n_out: int, n: int) -> str:
    """GCPs ``told`` (:func:`crop_reading`) that fit both as a crop's and as a copy's, in words: both readings and
    what to do about each."""
    s = told["scale"]
    return (f"{n_out} of {n} GCPs lie outside the image, spanning about {s:g}x its size, and the fit cannot tell "
            f"whether this image is a crop of the one they were measured on or they were measured on a copy about "
            f"{s:g}x this image's size (over flat terrain both fit): as given, {told['n_given']} control points "
            f"inside fit with {told['rms_given']:.2f} px RMS; read back (col/row ÷ {s:g}), {told['n_read_back']} fit "
            f"with {told['rms_read_back']:.2f} px; a crop of a flat scene cannot be told from a copy: give the image "
            f"the GCPs were measured on (the full frame), or each GCP's own height (a z field or a DEM, not one "
            f"constant height) where the ground has relief; if they were measured on a "
            f"copy, rescale them (col/row ÷ {s:g}); if this image is a crop, remove the GCPs outside it")
