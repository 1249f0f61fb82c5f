"""The rules that hold interior parameters fixed in a bundle adjustment (:mod:`fotogeo.orientation.bundle`).

*Correlation rule*: a free interior parameter the block cannot tell from the exterior orientation — its multiple
correlation ``ϱ`` with the other camera-side unknowns above ``max_correlation`` *and* its a-posteriori σ moving
the image points by more than :data:`DETERMINED_PX` (or the image σ when larger;
:func:`~fotogeo.orientation.bundle_robust.interior_correlations`) — is held fixed at its initial value, one at a
time, the block solved again after each.

*Significance rule* (Gruen 1985), for Ebner's (1976) additional parameters: one whose change from its initial
value is below ``significance`` times its σ is held fixed, all such at once, then the block is solved and tested
again.

Both verdicts scale with σ̂₀. Taken before data snooping, σ̂₀ still carries the blunders the robust phase did
not skip, and a parameter the clean block determines can read as undetermined. :func:`release` frees the
parameters held so far, for the adjustment to take both rules again on the block data snooping has cleaned
(:func:`fotogeo.orientation.bundle.adjust_block`).

The re-solving is the caller's: ``resolve(label) -> (pb, s, p)`` rebuilds the problem after a parameter was held
fixed and solves it with the weights of the phase.
"""
from __future__ import annotations

import numpy as np

from ..options import EBNER_PARAMETERS
from . import bundle_jacobian as bj
from .bundle_robust import interior_correlations, posterior

#: an interior parameter whose a-posteriori σ moves the image points by at most this (px) is determined,
#: however correlated: half a pixel, well within what a camera guessed from EXIF is off by
DETERMINED_PX = 0.5


def initial_interior(block) -> np.ndarray:
    """``(f, ppx, ppy, k1, k2, k3, p1, p2, b1 … b12)`` of the block's camera (Ebner's terms start at 0)."""
    return np.array([block.camera.focal_length, *block.camera.principal_point, *block.distortion,
                     *np.zeros(len(EBNER_PARAMETERS))], dtype=np.float64)


def hold_fixed(run, name, entry, fixed) -> None:
    """Hold interior parameter ``name`` fixed at its initial value; ``entry`` (why) appended to ``fixed``."""
    k = bj.INTERIOR_NAMES.index(name)
    run.free.remove(k)
    run.interior[k] = initial_interior(run.block)[k]
    fixed.append(entry)


def release(run, fixed) -> list:
    """Free again every parameter in ``fixed`` (at its initial value, where it was held) and empty ``fixed``;
    the entries released."""
    released = list(fixed)
    run.free = sorted(set(run.free) | {bj.INTERIOR_NAMES.index(f["parameter"]) for f in released})
    fixed.clear()
    return released


def correlation_rule(run, pb, s, p, opts, resolve, fixed):
    """Hold fixed, one at a time, the interior parameters the block cannot tell from the exterior
    orientation (module docstring); ``(pb, s, p)`` after the last re-solve."""
    while run.free:
        corr = interior_correlations(pb, posterior(pb, s, p), run.block.frames, bj.INTERIOR_NAMES)
        worst = _to_fix(corr, opts.max_correlation)
        if worst is None:
            break
        k = bj.INTERIOR_NAMES.index(worst["parameter"])  # its estimate while free, for a caller to compare
        hold_fixed(run, worst["parameter"], {**worst, "estimate": float(s.interior[k]),
                                             "reason": _fix_reason(worst, opts.max_correlation)}, fixed)
        pb, s, p = resolve("after fixing a parameter")
    return pb, s, p


def significance_rule(run, pb, s, p, opts, resolve, fixed):
    """The precision companion of the correlation rule, for Ebner's additional parameters: one whose
    change from its initial value is below ``opts.significance`` times its a-posteriori σ
    (``|b − b₀| < t·σ_b``: the block does not show that error) is held fixed as not significant
    (Gruen 1985: additional parameters are kept only where the block determines them); all such
    parameters at once, then the block is solved and tested again."""
    initial = initial_interior(run.block)
    while opts.significance > 0 and any(bj.INTERIOR_NAMES[k] in EBNER_PARAMETERS for k in run.free):
        post = posterior(pb, s, p)
        sd = post.sigma0 * np.sqrt(np.maximum(np.diag(post.S_inv)[6 * pb.st.n_frames:], 0.0))
        weak = []
        for q, k in enumerate(pb.st.free_interior):
            name, value = bj.INTERIOR_NAMES[k], float(run.interior[k])
            t = abs(value - initial[k]) / sd[q] if sd[q] > 0 else 0.0
            if name in EBNER_PARAMETERS and t < opts.significance:
                weak.append({"parameter": name, "value_px": value, "sigma_px": float(sd[q]), "t": float(t),
                             "reason": f"{name} is not significant: |{name}| = {abs(value):.3g} px < "
                                       f"{opts.significance:g} σ (σ = {sd[q]:.3g} px); held fixed at 0"})
        if not weak:
            break
        for entry in weak:
            hold_fixed(run, entry["parameter"], entry, fixed)
        pb, s, p = resolve("after fixing non-significant parameters")
    return pb, s, p


def _to_fix(corr, limit):
    """The interior parameter to hold fixed, or None: the one of largest multiple correlation above
    ``limit`` — unless its strongest partner is a higher-order free interior term (k2 for k1), which
    goes first (the lower-order term carries most of the effect)."""
    over = {c["parameter"]: c for c in corr if c["multiple_correlation"] > limit and not _determined(c)}
    if not over:
        return None
    worst = max(over.values(), key=lambda c: c["multiple_correlation"])
    partner = worst["partner"]
    if partner in over and bj.INTERIOR_NAMES.index(partner) > bj.INTERIOR_NAMES.index(worst["parameter"]):
        return over[partner]
    return worst


def _determined(c) -> bool:
    """Whether the block determines an interior parameter in spite of its correlation: its σ moves the image
    points by at most :data:`DETERMINED_PX` or their σ if larger (``σ_px``,
    :func:`~fotogeo.orientation.bundle_robust.interior_correlations`) — a principal point against the
    attitudes and the decentering terms (a shift of it is a tilt of the camera but for terms of second order
    in the image coordinates, which many rays determine)."""
    return bool(c.get("sigma_px", np.inf) <= max(DETERMINED_PX, c.get("image_sigma_px", 0.0)))


def _fix_reason(c, limit):
    moves = (f"its σ moves the image points by {c['sigma_px']:.3g} px, more than "
             f"{max(DETERMINED_PX, c['image_sigma_px']):.3g} px" if np.isfinite(c["sigma_px"]) else
             "its σ is undetermined")
    return (f"{c['parameter']} cannot be told from the exterior orientation: its multiple correlation with "
            f"the other unknowns is {c['multiple_correlation']:.4f} > {limit} (largest: "
            f"{c['correlation']:+.3f} with {c['partner']}) and {moves}; held fixed at its initial value")
