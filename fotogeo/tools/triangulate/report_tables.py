"""The tables of ``report.html`` beyond the summary (:mod:`fotogeo.tools.triangulate.report` draws the plots):
the adjusted orientations with the σ of position and angles, the mean σ of the adjusted points per type, the
largest image residuals with the adjusted image coordinates, the matching statistics and the timings — each a
view of the ``report.json`` entry of the same name (:mod:`fotogeo.tools.triangulate.statistics`)."""
from __future__ import annotations

import html

import numpy as np

RESIDUAL_ROWS = 30  # the largest image residuals listed in report.html
PAIR_ROWS = 40  # the weakest pairs listed in report.html
ROLE_LABELS = {"tie": "tie points", "control": "control points", "check": "check points",
               "rejected": "rejected control"}
STAGE_LABELS = {"inputs": "reading the inputs", "control": "control and approximate orientation",
                "matching": "tie-point matching", "adjustment": "bundle adjustment",
                "outputs": "outputs (orientations, layers, orthophotos)", "mosaic": "mosaic", "total": "total"}


def table(rows, head) -> str:
    """An HTML table, every cell escaped."""
    cells = "".join(f"<th>{html.escape(str(h))}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{cells}</tr>{body}</table>"


def fmt(x, digits=3) -> str:
    """A number with ``digits`` decimals, "–" for None or NaN."""
    return f"{x:.{digits}f}" if isinstance(x, (int, float)) and np.isfinite(x) else "–"


def start_section(start: dict, dropped: list) -> str:
    """Where the block's start came from (orientation, map CRS, GPS heights, the readers' notes) and the frames
    left out as undetermined, with why (``report.json`` ``start`` and ``dropped_frames``)."""
    rows = [(k, start[key]) for k, key in (("approximate orientation", "source"), ("map CRS", "crs_rule"),
                                           ("GPS heights", "heights")) if start.get(key)]
    notes = "".join(f"<li>{html.escape(str(n))}</li>" for n in start.get("notes") or [])
    out = "<h2>Start</h2>" + (table(rows, ("", "from")) if rows else "") + (f"<ul>{notes}</ul>" if notes else "")
    if dropped:
        out += ("<h2>Frames left out (undetermined)</h2>"
                + table([(d.get("name", ""), d.get("reason", "")) for d in dropped], ("frame", "why")))
    return out


def frames_section(frames: list) -> str:
    """The adjusted exterior orientation with the σ of the centre (m) and of the rotations about the camera
    axes (°, the ``frames`` layer's ``sigma_rx_deg`` …)."""
    rows = [(f["name"], fmt(f["X"]), fmt(f["Y"]), fmt(f["Z"]), fmt(f["omega"], 5), fmt(f["phi"], 5),
             fmt(f["kappa"], 5), fmt(f["sigma"]["X0"]), fmt(f["sigma"]["Y0"]), fmt(f["sigma"]["Z0"]),
             fmt(f["sigma"]["rx_deg"], 4), fmt(f["sigma"]["ry_deg"], 4), fmt(f["sigma"]["rz_deg"], 4)) for f in frames]
    return ("<h2>Adjusted exterior orientation</h2>"
            + table(rows, ("frame", "X", "Y", "Z", "ω°", "φ°", "κ°", "σX0 m", "σY0 m", "σZ0 m", "σ rx°", "σ ry°",
                           "σ rz°"))
            + "<p>σ rx, ry, rz: the rotations about the camera's x, y and z axes (degrees).</p>")


def point_sigma_section(by_role: dict) -> str:
    """Mean σX σY σZ of the adjusted points per point type."""
    rows = [(ROLE_LABELS.get(r, r), s["n"], fmt(s["sigma_x_m"]), fmt(s["sigma_y_m"]), fmt(s["sigma_z_m"]))
            for r, s in by_role.items()]
    return ("<h2>Mean σ of the adjusted points (m)</h2>"
            + (table(rows, ("", "n", "σX", "σY", "σZ")) if rows else "<p>no adjusted points</p>"))


def residuals_section(rows: list, n_all: int) -> str:
    """The largest image residuals, with the measured and the adjusted image coordinates."""
    shown = rows[:RESIDUAL_ROWS]
    body = [(r["frame"], r["point"], fmt(r["col"], 2), fmt(r["row"], 2), fmt(r["col_adjusted"], 2),
             fmt(r["row_adjusted"], 2), fmt(r["vx_px"], 3), fmt(r["vy_px"], 3), fmt(r["v_px"], 3), r["status"],
             fmt(r["w"], 2)) for r in shown]
    return (f"<h2>Largest image residuals</h2><p>The {len(shown)} largest of {n_all} observations, largest first "
            f"(v = projected − measured, px; adjusted = measured + v). report.json lists more, the residuals layer "
            f"of block.gpkg every one.</p>"
            + table(body, ("frame", "point", "col", "row", "col adj.", "row adj.", "vx", "vy", "|v|", "status", "w")))


def matching_section(summary: dict | None, matching: dict | None) -> str:
    """Pairs tried and matched, inliers per pair (the weakest pairs listed), rays per track."""
    if not summary:
        return "<h2>Tie-point matching</h2><p>image observations given; nothing matched</p>"
    ipp = summary["inliers_per_pair"] or {}
    head = [("pairs tried (footprints overlap)", summary["pairs_tried"]),
            ("pairs matched (≥ 1 epipolar inlier)", summary["pairs_matched"]),
            ("inliers per pair: min / median / max", f"{ipp.get('min', '–')} / {fmt(ipp.get('median'), 1)} / "
                                                     f"{ipp.get('max', '–')}"),
            ("detection pyramid level", (matching or {}).get("detection_level", "–")),
            ("tracks after matching", (matching or {}).get("tracks", "–"))]
    after = summary["rays_per_track_matched"] or {}
    adjusted = summary["rays_per_tie_point_adjusted"] or {}
    keys = sorted({*after, *adjusted}, key=int)
    rays = [(k, after.get(k, 0), adjusted.get(k, 0)) for k in keys]
    pairs = sorted((matching or {}).get("pairs", []), key=lambda p: p["inliers"])[:PAIR_ROWS]
    pair_rows = [(" – ".join(p.get("frames", map(str, p["pair"]))), p["matches"], p["inliers"]) for p in pairs]
    return ("<h2>Tie-point matching</h2>" + table(head, ("", "value"))
            + "<h3>Rays per track</h3>" + table(rays, ("rays", "tracks after matching", "tie points adjusted"))
            + f"<h3>Inliers per pair</h3><p>The {len(pair_rows)} weakest of {summary['pairs_tried']} pairs (fewest "
              f"epipolar inliers first); report.json lists every pair.</p>"
            + table(pair_rows, ("pair", "matches", "epipolar inliers")))


def mosaic_section(mosaic: dict | None, resolution) -> str:
    """The mosaic written (size, pixel size, images) or why there is none; nothing without ``mosaic``."""
    if not mosaic:
        return ""
    if "error" in mosaic:
        return f"<h2>Mosaic</h2><p>{html.escape(mosaic['error'])}</p>"
    rows = [("mosaic", mosaic["output"]), ("seamlines", mosaic["seamlines"]),
            ("size (px)", f"{mosaic['width']} × {mosaic['height']}"), ("pixel size (m)", fmt(resolution, 3)),
            ("orthophotos", len(mosaic["images"])), ("feather width (m)", fmt(mosaic["feather_m"], 1))]
    return "<h2>Mosaic</h2>" + table(rows, ("", "value"))


def timings_section(timings: dict) -> str:
    """Wall-clock seconds of the stages and of the adjustment's own steps."""
    staged = "adjustment_steps" in timings  # else (a report without stages): the adjustment's steps alone
    rows = [(STAGE_LABELS[k], fmt(timings[k], 2)) for k in STAGE_LABELS if k in timings] if staged else []
    steps = [(k, fmt(v, 2)) for k, v in (timings["adjustment_steps"] if staged else timings).items()]
    return ("<h2>Timings (s)</h2>" + table(rows, ("stage", "s"))
            + ("<h3>Bundle adjustment steps</h3>" + table(steps, ("step", "s")) if steps else ""))
