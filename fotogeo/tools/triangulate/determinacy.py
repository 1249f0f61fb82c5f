"""The adjustment with every frame's determinacy checked (:func:`adjust_determined`): a frame the block does not
determine is dropped and the block adjusted again (``undetermined="drop"``, the default), or fails the run by name
(``undetermined="fail"``); a frame whose attitude prior its tie points contradict is first re-started from the block.

* **Dropping, and when it is refused**: as photogrammetric packages leave unaligned cameras out, an undetermined
  frame is left out by default — named with its reason in the report and the console, never silently. Dropping is
  refused (the run fails naming the frames) when fewer than 2 frames would remain, or when more than half of the
  frames given (:data:`MAX_DROPPED_SHARE`) would be dropped: a flight mostly undetermined is a failed flight, not a
  smaller block to be delivered as a success.

* **The checks** (:mod:`fotogeo.orientation.bundle_quality`): points, spread, angle σ, position σ against
  ``D̄ · tan(max_angle_sigma)``, share of blunders, and the agreement of every frame with its GNSS/attitude
  priors (Baarda's test on the prior residuals).
* **Re-start of a contradicted attitude**: a frame failed only because its adjusted attitude departs from its
  attitude prior (the position agrees with its GNSS, every other check passes) may carry a wrong gimbal/INS tag
  rather than wrong ties — the test cannot tell them apart (the rendered oblique block, seed 2: DJI_205 and
  DJI_405 carry gimbal tags 21.2° and 18.4° from the truth, their ties are right). Such a frame, the most
  contradicted first, is re-oriented by single-frame space resection (:func:`~.inputs.resect`) from its used
  observations of points the other frames determine (≥ 2 rays without it) at their adjusted coordinates, its
  attitude prior is dropped (its position prior kept, the start's centre unchanged), and the block adjusted
  again. The re-start is kept only if that frame then passes every check — now without the prior's exemption:
  the images alone must hold its attitude to ``max_angle_sigma``, and its position must still agree with its GNSS;
  otherwise the first adjustment stands and the frame is refused or dropped as before. Wrong ties that turn a
  frame also pull its centre from the GNSS (seed 1: DJI_301 25.7 m from its GPS): a frame whose position is
  contradicted is never re-started.
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from ...errors import FotogeoWarning, InputError, ModelError
from ...geometry.attitude import rotation_angle
from ...orientation.bundle import adjust_block
from ...orientation.bundle_problem import eo_weights
from ...orientation.bundle_quality import (frame_quality, prior_contradicted_frames, prior_held_frames,
                                           prior_tests, sparse_frames, undetermined_frames)

#: points a re-started frame's resection needs (each determined by ≥ 2 other frames)
MIN_RESECTION_POINTS = 6
#: the largest share of the frames given that a run may drop as undetermined; beyond it the run is refused
MAX_DROPPED_SHARE = 0.5
#: the reason of a frame that lost every tie point
LONELY = "reached by no tie point (or fewer than 3 observations)"


def why_not_dropped(total: int, left: int) -> str | None:
    """Why dropping cannot help when ``left`` of the ``total`` frames given would remain (fewer than 2, or more
    than :data:`MAX_DROPPED_SHARE` of them dropped), as the clause of a refusal; None when dropping may go on."""
    if left < 2:
        return (f"dropping them (--undetermined drop) would leave {left} frame(s), fewer than the 2 a block "
                f"needs")
    if total - left > MAX_DROPPED_SHARE * total:
        return (f"dropping them (--undetermined drop) would leave {left} of the {total} frames: with more than "
                f"half of the frames undetermined the rest is no block to trust")
    return None


def adjust_determined(block, opts, kw, prog, dropped_before: int = 0, sigma_source: str | None = None,
                      final: dict | None = None):
    """``(result, block, FrameQuality, dropped, restarted)``: the adjustment, every frame checked (module
    docstring); an undetermined frame is dropped and the block adjusted again (``undetermined="drop"``), or fails
    the run. Frames whose observations are too few or too clustered even before any is rejected
    (:func:`~fotogeo.orientation.bundle_quality.sparse_frames`) are refused or dropped before the first adjustment,
    in seconds rather than after it. ``dropped_before``: frames of the flight already left out (e.g. by the
    registration start), counted in the share that may be dropped. ``dropped`` and ``restarted`` are lists of
    ``{"name", "reason"}``. ``sigma_source``: where the position priors' σ came from (:func:`free_roll`).
    ``final``: a dict that receives the options the returned result was adjusted with (``"opts"``: dropping or
    restarting a frame changes them), to adjust that block again."""
    dropped, restarted = [], []
    total = len(block.frames) + dropped_before
    sparse = sparse_frames(block, min_points=kw["min_frame_points"])
    if sparse:  # refused (or dropped) before adjusting: no adjustment can give them points
        block, opts = _refused_or_dropped(sparse, set(sparse), block, opts, kw, dropped, total)
    while True:
        free = free_roll(block, opts, sigma_source)
        if free:  # of the frames left: no adjustment can fix it, dropping more cannot help; refused before adjusting
            raise ModelError(free + (f" (dropped already: {', '.join(d['name'] for d in dropped)})" if dropped else ""),
                             frames=block.frames)  # every frame rolls: a caller may say what their files lost
        try:
            result = adjust_block(block, opts, progress=prog)
        except ModelError as e:  # frames that lost their tie points (to snooping): dropped on request
            lonely = set(getattr(e, "frames", ()))
            if not lonely or kw["undetermined"] != "drop":
                raise
            block, opts = _refused_or_dropped({n: LONELY for n in sorted(lonely)}, lonely, block, opts, kw, dropped,
                                              total)
            continue
        checks = _checked(result, block, opts, kw, restarted)
        again = _restart(result, block, opts, kw, prog, checks, restarted)
        if again is not None:
            block, opts, result, checks = again
        quality, own, contradicted, _ = checks
        bad = _merged(own, contradicted)
        drop = set(own) or set(list(contradicted)[:1])  # one wrong frame pulls its neighbours: one at a time
        if not bad:
            _warn_prior_held(quality, kw["max_angle_sigma"], block, opts)
            if final is not None:
                final["opts"] = opts
            return result, block, quality, dropped, [r for r in restarted if r["name"] in block.frames]
        block, opts = _refused_or_dropped(bad, drop, block, opts, kw, dropped, total)


def free_roll(block, opts, source: str | None = None) -> str | None:
    """The refusal when the datum leaves the block free to roll: no GCP or control point, no attitude prior, and
    the frames whose position has a prior (GNSS, ``--eo-sigma-position``) have their centres on one line — two
    frames always do, a straight strip nearly. A rotation of the whole block about that line moves no centre and
    changes no image residual: the normal equations are singular (a datum defect of one rotation; Granshaw 1980),
    however many tie points. The line is fitted to the centres (principal axis); "on it" means the centres' RMS
    distance from it is at most the largest position σ (the roll's σ, about σ / distance in radians, is then a
    radian or more). None when something else fixes the rotation. Checked on the frames left each time before
    adjusting (:func:`adjust_determined`): a frame off the line that is dropped no longer holds the roll.
    ``source``: where the position σ came from, as the refusal says it after the σ (e.g. "from the images' GNSS
    accuracy tags", :meth:`~.sources.BlockStart.sigma_source`; None: ``--eo-sigma-position``)."""
    m = len(block.frames)
    w = eo_weights(opts.eo_sigma, m)
    held = (w[:, :3] > 0).all(axis=1)
    if (w[:, 3:] > 0).any() or np.isin(np.asarray(block.role), ("control",)).any() or held.sum() < 2:
        return None
    c = np.array([e.centre for e in block.eo], float).reshape(m, 3)[held]
    sv = np.linalg.svd(c - c.mean(axis=0), compute_uv=False)
    off = float(sv[1] / np.sqrt(len(c)))
    sigma = float(np.max(1.0 / np.sqrt(w[held, :3])))
    if off > sigma:
        return None
    line = ("the 2 centres make one line" if len(c) == 2 else
            f"the {len(c)} centres lie on one line within their σ ({off:.2g} m RMS from it)")
    held_by = f"σ {sigma:g} m {source}" if source else f"--eo-sigma-position {sigma:g} m"
    return (f"only the positions of the frames are held ({held_by}), and {line}: a rotation "
            f"of the whole block about that line (the "
            f"roll about the base) moves no centre and no image point, so the adjustment cannot determine the "
            f"frames' attitude (no angle σ: the normal equations are singular) — give the attitude a prior "
            f"(--eo-sigma-angle, e.g. the INS/gimbal accuracy in degrees), a frame off that line, or ground "
            f"control (--gcps, or --reference with --dem)")


def _refused_or_dropped(bad: dict, drop: set, block, opts, kw, dropped: list, total: int):
    """The block and options without the frames ``drop`` (appended to ``dropped`` with their reasons from ``bad``),
    or the refusal naming the frames ``bad`` when ``undetermined`` is not "drop" or dropping would leave too few of
    the ``total`` frames given (:func:`why_not_dropped`)."""
    text = frames_text(bad)
    left = len(block.frames) - len(drop)
    refusal = why_not_dropped(total, left) if kw["undetermined"] == "drop" else None
    if kw["undetermined"] != "drop" or refusal:
        if refusal and dropped:  # the frames dropped before count too: name them
            refusal += f" (dropped already: {', '.join(d['name'] for d in dropped)})"
        raise ModelError(_undetermined_message(text, refusal), frames=bad)
    dropped += [{"name": n, "reason": why} for n, why in bad.items() if n in drop]
    return without_frames(block, opts, drop)


def frames_text(bad: dict, reasons: int = 3) -> str:
    """``{frame: reason}`` for a one-line refusal: the first ``reasons`` frames with their reasons, every further
    one by name (a flight mostly refused is named whole, its line still short)."""
    items = list(bad.items())
    text = "; ".join(f"{n}: {why}" for n, why in items[:reasons])
    rest = [n for n, _ in items[reasons:]]
    return text + (f"; and {len(rest)} more: {', '.join(rest)}" if rest else "")


def _undetermined_message(text: str, why_not_dropped: str | None) -> str:
    """The refusal of undetermined frames; when dropping them was refused, why (:func:`why_not_dropped`)."""
    fix = ("add tie points or GCPs there, give or check their attitude and position (--eo, --geoinfo, gimbal and GPS "
           "tags, --eo-sigma-angle, --eo-sigma-position)")
    if why_not_dropped:
        return (f"the block does not determine frame(s) {text} — their orientation cannot be trusted, and "
                f"{why_not_dropped}; {fix}")
    return (f"the block does not determine frame(s) {text} — their orientation cannot be trusted; {fix}, or leave "
            f"them out (--undetermined drop)")


def _checked(result, block, opts, kw, restarted):
    """``(FrameQuality, {frame: reason} of the determinacy checks, {frame: reason} of the prior test (most
    contradicted first), {frame: failed prior groups})``."""
    quality = frame_quality(result, block)
    m = len(block.frames)
    own = undetermined_frames(quality, min_points=kw["min_frame_points"], max_angle_sigma=kw["max_angle_sigma"],
                              angle_prior=_has_prior(opts.eo_sigma, m, 3),
                              position_prior=_has_prior(opts.eo_sigma, m, 0),
                              in_block=np.isin(block.frames, [r["name"] for r in restarted]))
    return quality, own, prior_contradicted_frames(result, block, opts.eo_sigma), prior_tests(result, block,
                                                                                           opts.eo_sigma)


def _merged(own: dict, contradicted: dict) -> dict:
    """``{frame: every reason}`` of the frames failing any check."""
    bad = dict(own)
    for n, why in contradicted.items():
        bad[n] = f"{bad[n]}; {why}" if n in bad else why
    return bad


def _warn_prior_held(quality, max_angle_sigma: float, block=None, opts=None) -> None:
    text = prior_held_warning(quality, max_angle_sigma, block, opts)
    if text:
        warnings.warn(text, FotogeoWarning, stacklevel=3)


def prior_held_warning(quality, max_angle_sigma: float, block=None, opts=None) -> str | None:
    """The warning for frames whose angle σ exceeds ``max_angle_sigma`` (their attitude rests on its prior), with
    what this flight's geometry cannot fix (:func:`tilt_left_free`); None when no frame does."""
    held = prior_held_frames(quality, max_angle_sigma)
    if not held:
        return None
    why, fix = tilt_left_free(block, opts) if block is not None else (None, "add GCPs")
    return (f"{len(held)} frame(s) keep an angle σ above {max_angle_sigma:g}° (up to {max(held.values()):.3g}°): "
            f"the images tie them but their absolute attitude rests on its prior"
            + (f" ({why})" if why else "") + f"; {fix}")


#: the centres' spread across over along their principal axis below which the flight is one line (a strip)
LINE_ASPECT = 0.25


def tilt_left_free(block, opts) -> tuple:
    """``(what this flight cannot fix, the fix)``. A rotation ``θ`` of the whole block about a horizontal axis
    through the centres' mean moves centre ``i`` vertically by ``θ·dᵢ`` (``dᵢ`` its horizontal distance from the
    axis), so height priors of σ ``σ_z`` fix it to ``σ_θ = σ_z / √(Σ dᵢ²)``, weakest about the centres' principal
    (longest) horizontal axis, where ``Σ dᵢ² = n·λ_min`` of their horizontal covariance. A strip (spread across
    below :data:`LINE_ASPECT` of the spread along) leaves its roll about the line to the attitude prior; a block,
    a ring or a cross pattern leaves the tilt of the whole block at ``σ_θ``; with control points, or without
    position priors on two frames, the frames' own ties are named instead."""
    m = len(block.frames)
    w = eo_weights(opts.eo_sigma, m)
    held = (w[:, :3] > 0).all(axis=1)
    if np.isin(np.asarray(block.role), ("control",)).any() or held.sum() < 2:
        return "their own tie points do not fix it", "add tie points around those frames or GCPs they see"
    c = np.array([e.centre for e in block.eo], float).reshape(m, 3)[held]
    lam, vec = np.linalg.eigh(np.cov((c[:, :2] - c[:, :2].mean(axis=0)).T, bias=True))
    along, across = (np.ptp((c[:, :2] - c[:, :2].mean(axis=0)) @ vec[:, k]) for k in (1, 0))
    sigma_z = float(np.max(1.0 / np.sqrt(w[held, 2])))
    tilt = np.degrees(sigma_z / np.sqrt(max(len(c) * lam[0], 1e-12)))
    bearing = np.degrees(np.arctan2(vec[0, 1], vec[1, 1])) % 180.0
    bound = f"to {tilt:.2g}° at best" if tilt < 10 else "hardly at all"
    if across < LINE_ASPECT * along:
        return (f"the {len(c)} centres fly one line, {along:.0f} m long and {across:.0f} m across: their positions "
                f"(σ {sigma_z:g} m in height) fix the roll about that line {bound}"), \
            "add GCPs or a cross strip"
    return (f"the {len(c)} centres spread {along:.0f} × {across:.0f} m: their positions (σ {sigma_z:g} m in height) "
            f"fix the tilt of the whole block {bound}, about the axis at bearing {bearing:.0f}°"), \
        "add GCPs or more precise positions (RTK/PPK, --eo-sigma-position)"


def _restart(result, block, opts, kw, prog, checks, restarted):
    """The block adjusted again with the most contradicted re-startable frame re-oriented by resection and its
    attitude prior dropped (module docstring), ``(block, opts, result, checks)``, repeated while frames qualify;
    None when none qualifies or the first re-start fails its checks (a later failing one is not kept either)."""
    done = {r["name"] for r in restarted}
    out = None
    while True:
        _, own, contradicted, tests = checks
        name = next((n for n in contradicted if n not in done and n not in own and set(tests[n]) == {"attitude"}),
                    None)
        if name is None:
            return out
        done.add(name)
        try:
            new_block, new_opts = restarted_frame(block, opts, result, name)
            new_result = adjust_block(new_block, new_opts, progress=prog)
        except (InputError, ModelError):
            return out
        new_checks = _checked(new_result, new_block, new_opts, kw, [*restarted, {"name": name}])
        if name in new_checks[1] or name in new_checks[2]:
            return out
        size, sigma, t, crit = tests[name]["attitude"]
        j = new_block.frames.index(name)
        tag = rotation_angle(block.eo[j].rotation, new_result.eo[j].rotation)
        inner = float(new_checks[0].angle_sigma_in_block[j])
        restarted.append({"name": name, "reason": f"its attitude prior contradicted (adjusted {size:.3g}° from it, σ "
                                                  f"{sigma:.3g}°, test {np.sqrt(t):.2f} > {np.sqrt(crit):.2f}); "
                                                  f"re-oriented by resection from the block and adjusted without that "
                                                  f"prior, it passes every check: {tag:.3g}° from the prior, angle σ "
                                                  f"in the block {inner:.2g}°", "prior_offset_deg": tag,
                          "angle_sigma_deg": float(new_checks[0].angle_sigma[j]), "angle_sigma_in_block_deg": inner})
        block, opts, result, checks = new_block, new_opts, new_result, new_checks
        out = (block, opts, result, checks)


def restarted_frame(block, opts, result, name):
    """``(block, opts)`` with frame ``name``'s approximate attitude from space resection against the points the
    other frames determine (adjusted coordinates; its centre kept, the prior of its position) and its attitude
    prior dropped; InputError when fewer than :data:`MIN_RESECTION_POINTS` such points or no fit."""
    from .inputs import resect
    j = block.frames.index(name)
    used = result.status == "used"
    others = np.bincount(block.obs_point[used & (block.obs_frame != j)], minlength=len(block.point_ids))
    own = np.flatnonzero(used & (block.obs_frame == j))
    own = own[(others[block.obs_point[own]] >= 2) & np.isfinite(result.point_xyz[block.obs_point[own]]).all(axis=1)]
    if len(own) < MIN_RESECTION_POINTS:
        raise InputError(f"frame {name}: {len(own)} points determined by the other frames")
    eo = resect(block.camera, block.distortion, result.point_xyz[block.obs_point[own]], block.obs_pixel[own], name)
    start = list(block.eo)
    start[j] = replace(start[j], omega=eo.omega, phi=eo.phi, kappa=eo.kappa)
    sigma = prior_sigmas(opts.eo_sigma, len(block.frames))
    sigma[j, 3:] = np.inf
    return replace(block, eo=tuple(start)), replace(opts, eo_sigma=sigma)


def prior_sigmas(eo_sigma, m: int) -> np.ndarray:
    """``(m, 6)`` σ of the orientation priors (m, °; inf: free), as :func:`eo_weights` reads ``eo_sigma``."""
    w = eo_weights(eo_sigma, m)
    with np.errstate(divide="ignore"):
        s = np.where(w > 0, 1.0 / np.sqrt(np.where(w > 0, w, 1.0)), np.inf)
    s[:, 3:] = np.degrees(s[:, 3:])
    return s


def _has_prior(eo_sigma, m: int, first: int) -> np.ndarray:
    """``(m,)`` True where the frame's angles (``first`` 3) or position (``first`` 0) have a prior
    (:func:`~fotogeo.orientation.bundle_problem.eo_weights`)."""
    return (eo_weights(eo_sigma, m)[:, first:first + 3] > 0).all(axis=1)


def without_frames(block, opts, names):
    """The block and options without the frames ``names`` (their observations and EO priors)."""
    keep_f = np.array([f not in names for f in block.frames])
    new_index = np.cumsum(keep_f) - 1
    keep_o = keep_f[block.obs_frame]
    block = replace(block, frames=tuple(f for f, k in zip(block.frames, keep_f) if k),
                    eo=tuple(e for e, k in zip(block.eo, keep_f) if k), obs_frame=new_index[block.obs_frame[keep_o]],
                    obs_point=block.obs_point[keep_o], obs_pixel=block.obs_pixel[keep_o],
                    obs_sigma=None if block.obs_sigma is None else np.asarray(block.obs_sigma)[keep_o])
    sig = opts.eo_sigma
    if sig is not None and np.ndim(sig) == 2:
        opts = replace(opts, eo_sigma=np.asarray(sig)[keep_f])
    return block, opts
