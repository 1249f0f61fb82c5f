"""Culling blunders in a bundle adjustment (:mod:`fotogeo.orientation.bundle`): the observations the robust
phase skipped, and Baarda's (1968) data snooping by standardised residuals, one round at a time."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .bundle_robust import largest_w, skipped, worst_per_point


def cull_skipped(run, pb, s, huber) -> list:
    """Deactivate the tie and check observations the robust phase skipped at its solution
    (:func:`~fotogeo.orientation.bundle_robust.skipped`); their blunder records (round 0)."""
    block = run.block
    skip, e, v = skipped(pb, s, huber, block.role[pb.point_ids[pb.st.point]] == "control")
    run.active[pb.obs_ids[skip]] = False
    obs = pb.obs_ids[skip]
    return [{"observation": int(o), "kind": "image", "frame": block.frames[block.obs_frame[o]],
             "point": block.point_ids[block.obs_point[o]], "w": float(e[a]), "residual_px": float(np.hypot(*v[a])),
             "round": 0} for o, a in zip(obs, skip)]


def snoop_round(run, pb, post, opts, rnd, blunders) -> bool:
    """One round of data snooping (:mod:`~fotogeo.orientation.bundle_robust`): demote the worst
    flagged control point, or cull the worst flagged observation of every point (a flagged tie or
    check point left with < 3 rays is dropped); True when something changed."""
    block = run.block
    wc = np.where(np.isfinite(post.w_control), post.w_control, -np.inf).max(axis=1)
    n_ctrl = int(np.count_nonzero(np.isfinite(wc)))
    if n_ctrl and wc.max() > opts.critical_w and (n_ctrl > 3 or opts.eo_sigma is not None):
        i = int(np.argmax(wc))
        pid = int(pb.point_ids[i])
        role = block.role.astype(object)
        role[pid] = "rejected"
        run.block = replace(block, role=role.astype(str))
        blunders.append({"point": block.point_ids[pid], "kind": "control", "w": float(wc[i]),
                         "residual_m": [float(x) for x in pb.ctrl_xyz[i] - run.X[pid]], "round": rnd + 1})
        return True
    worst, cull = worst_per_point(pb, post.w, opts.critical_w, block.role[pb.point_ids] != "control")
    for a in worst:
        o = int(pb.obs_ids[a])
        blunders.append({"observation": o, "kind": "image", "frame": block.frames[block.obs_frame[o]],
                         "point": block.point_ids[block.obs_point[o]], "w": float(largest_w(post.w[a:a + 1])[0]),
                         "residual_px": float(np.hypot(*post.v[a])), "round": rnd + 1})
    run.active[pb.obs_ids[cull]] = False
    return worst.size > 0
