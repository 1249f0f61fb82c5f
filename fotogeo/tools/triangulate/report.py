"""The readable report of ``fotogeo triangulate``: ``report.html`` with embedded PNG plots.

Three plots, drawn with OpenCV (no plotting library needed), embedded as base64 PNG:

* **residual vectors per frame** — one panel per frame (the image rectangle, up to 4 in a row,
  360 px high, its name cut to the panel's width above it), the mean image residual
  ``projected − measured`` of the used observations in each cell of a 12 × 12 grid, exaggerated by
  the factor the caption gives; culled blunders as red dots (the caption is the legend);
* **residual histogram** — the lengths ``|v|`` (px) of the used observations' residuals;
* **control layout** — the frame footprints on the ground, control (green triangles), check
  (blue circles) and rejected (red crosses) points with their planimetric ``adjusted − given``
  vectors, exaggerated by the factor printed.

Captions and legends are HTML under each plot (they wrap; text drawn into a plot was cut at its
edge). The tables beside them repeat ``report.json``: σ₀, image RMS, check RMSE, control placed by
the images alone and the σ-weighted control residuals per axis, interior parameters held fixed and
why, blunders; then (:mod:`fotogeo.tools.triangulate.report_tables`) the adjusted orientations with the σ
of position and angles, the mean σ of the adjusted points per type, the largest image residuals with the
adjusted image coordinates, the matching statistics and the timings of every stage. The CRS is named in one line, its WKT folded
and wrapped.
"""
from __future__ import annotations

import base64
import html

import cv2
import numpy as np

from . import report_tables as rt

GRID = 12  # cells per image side of the per-frame residual panels
BLACK, GREY, RED, GREEN, BLUE = (0, 0, 0), (170, 170, 170), (0, 0, 220), (0, 150, 0), (200, 90, 0)  # BGR


def _png(img) -> str:
    ok, buf = cv2.imencode(".png", img)
    return base64.b64encode(buf.tobytes()).decode("ascii") if ok else ""


def _text(img, text, xy, scale=0.45, color=BLACK):
    cv2.putText(img, text, (int(xy[0]), int(xy[1])), cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def _fit_text(text: str, width: int, scale: float) -> str:
    """``text`` cut from the left (".." + its end: frame names differ at the end) to fit ``width`` px at ``scale``.

    >>> _fit_text("3324c_2015_1004_05_0182_RGB", 120, 0.45)
    '.._05_0182_RGB'
    """
    def wide(t):
        return cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0] > width
    if not wide(text):
        return text
    k = 1
    while k < len(text) and wide(".." + text[k:]):
        k += 1
    return ".." + text[k:]


def residual_panels(result, block, panel: int = 360, max_frames: int = 48) -> tuple:
    """The per-frame residual-vector plot (module docstring): ``(BGR image, caption)``."""
    w, h = block.camera.image_size
    k = panel / max(w, h)
    pw, ph = int(w * k), int(h * k)
    m = min(len(block.frames), max_frames)
    cols = min(m, 4)
    rows = -(-m // cols)
    gap, top = 24, 26
    used = result.status == "used"
    v = result.residuals
    rms = float(np.sqrt(np.nanmean(np.sum(v[used] ** 2, axis=1)))) if used.any() else 1.0
    ex = 0.4 * panel / GRID / max(rms, 1e-6)  # an RMS-sized vector spans 40 % of a cell
    img = np.full((rows * (ph + top + 8) + 8, cols * (pw + gap) + gap, 3), 255, np.uint8)
    for j in range(m):
        x0, y0 = gap + (j % cols) * (pw + gap), top + (j // cols) * (ph + top + 8)
        cv2.rectangle(img, (x0, y0), (x0 + pw, y0 + ph), GREY, 1)
        _text(img, _fit_text(block.frames[j], pw + gap - 4, 0.45), (x0, y0 - 8), 0.45)
        sel = used & (block.obs_frame == j)
        px = block.obs_pixel[sel]
        cell = (np.minimum((px[:, 1] / h * GRID).astype(int), GRID - 1) * GRID
                + np.minimum((px[:, 0] / w * GRID).astype(int), GRID - 1))
        for c in np.unique(cell):
            at = cell == c
            p, d = px[at].mean(axis=0) * k, v[sel][at].mean(axis=0) * ex
            a, b = (int(x0 + p[0]), int(y0 + p[1])), (int(x0 + p[0] + d[0]), int(y0 + p[1] + d[1]))
            cv2.arrowedLine(img, a, b, BLUE, 1, cv2.LINE_AA, tipLength=0.3)
        for p in block.obs_pixel[(result.status == "blunder") & (block.obs_frame == j)] * k:
            cv2.circle(img, (int(x0 + p[0]), int(y0 + p[1])), 3, RED, -1)
    n_bl = int(np.count_nonzero(result.status == "blunder"))
    caption = (f"{_swatch('#005ac8', '→')} mean image residual (projected − measured) per cell of a {GRID}×{GRID} "
               f"grid, drawn ×{ex:.0f} (RMS vector length {rms:.2f} px); {_swatch('#dc0000', '●')} observations "
               f"culled as blunders ({n_bl})" + (f"; the first {m} of {len(block.frames)} frames"
                                                  if m < len(block.frames) else ""))
    return img, caption


def _swatch(color: str, mark: str) -> str:
    return f"<b style='color:{color}'>{mark}</b>"


def histogram(result, size=(640, 320), bins: int = 30) -> np.ndarray:
    """The residual-length histogram (module docstring) as a BGR image."""
    W, H = size
    img = np.full((H, W, 3), 255, np.uint8)
    r = np.hypot(*result.residuals[result.status == "used"].T)
    if len(r) == 0:
        return img
    top = float(np.percentile(r, 99.5)) or 1.0
    counts, edges = np.histogram(np.minimum(r, top), bins=bins, range=(0.0, top))
    x0, y0, pw, ph = 60, H - 40, W - 80, H - 70
    for i, c in enumerate(counts):
        bh = int(ph * c / max(counts.max(), 1))
        cv2.rectangle(img, (x0 + i * pw // bins, y0 - bh), (x0 + (i + 1) * pw // bins - 2, y0), BLUE, -1)
    cv2.line(img, (x0, y0), (x0 + pw, y0), BLACK, 1)
    for t in np.linspace(0.0, top, 5):
        _text(img, f"{t:.2f}", (x0 + t / top * pw - 12, y0 + 18), 0.4)
    _text(img, f"|residual| px ({len(r)} observations; last bin includes > {top:.2f})", (x0, H - 6), 0.45)
    _text(img, f"max count {int(counts.max())}", (x0, 20), 0.45)
    return img


def control_layout(result, block, footprints, size: int = 640) -> tuple:
    """The control layout (module docstring): ``(BGR image, caption)``."""
    import shapely
    img = np.full((size, size, 3), 255, np.uint8)
    known = (result.roles != "tie") & np.isfinite(block.point_xyz).all(axis=1)
    outlines = [np.asarray(shapely.get_coordinates(p)) for p in footprints["geometry"] if not p.is_empty]
    pts = np.vstack(outlines + [block.point_xyz[known, :2]]) if outlines or known.any() else np.zeros((1, 2))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    k = (size - 80) / max(float(np.max(hi - lo)), 1e-9)

    def to_px(xy):
        xy = np.atleast_2d(xy)
        return np.column_stack([40 + (xy[:, 0] - lo[0]) * k, size - 40 - (xy[:, 1] - lo[1]) * k]).astype(np.int32)
    for o in outlines:
        cv2.polylines(img, [to_px(o[:, :2])], True, GREY, 1, cv2.LINE_AA)
    d = result.point_xyz[known, :2] - block.point_xyz[known, :2]
    dl = np.hypot(*d.T) if len(d) else np.zeros(0)
    scale = 0.05 * size / k / max(float(np.nanmax(dl, initial=0.0)), 1e-6)  # the largest vector: 5 % of the plot
    for xy, dd, role in zip(block.point_xyz[known, :2], d, result.roles[known]):
        p = tuple(to_px(xy)[0])
        if np.isfinite(dd).all():
            cv2.arrowedLine(img, p, tuple(to_px(xy + dd * scale)[0]), BLACK, 1, cv2.LINE_AA, tipLength=0.25)
        if role == "control":
            cv2.drawMarker(img, p, GREEN, cv2.MARKER_TRIANGLE_UP, 10, 2)
        elif role == "check":
            cv2.circle(img, p, 5, BLUE, 2)
        else:
            cv2.drawMarker(img, p, RED, cv2.MARKER_TILTED_CROSS, 10, 2)
    caption = (f"{_swatch('#aaaaaa', '□')} frame footprints, {_swatch('#009600', '▲')} control, "
               f"{_swatch('#005ac8', '○')} check, {_swatch('#dc0000', '✕')} rejected control; " +
               (f"black vectors: adjusted − given in X, Y, drawn ×{scale:.0f}" if np.nanmax(dl, initial=0.0) > 0 else
                "no control or check point: the footprints alone" if not known.any() else
                "every adjusted point on its given position"))
    return img, caption


def _accuracy_rows(st: dict) -> list:
    """Rows of the accuracy table: check points, control placed by the images alone, σ-weighted control."""
    rows = []
    for key, label in (("check", "check points (not in the adjustment)"),
                       ("control_images", "control placed by the images alone"),
                       ("control", "control adjusted − given (σ-weighted)")):
        s = st.get(key) or {}
        if s.get("n"):
            rows.append((label, s["n"], *(rt.fmt(s.get(f"rmse_{a}_m")) for a in ("x", "y", "z", "planimetric"))))
    return rows


def _crs_block(text: str) -> str:
    """The CRS named in one line, its full text folded and wrapped."""
    from ...crs import crs_summary
    return (f"<p>CRS {html.escape(crs_summary(text))} <details><summary>full definition</summary>"
            f"<pre class='wrap'>{html.escape(text)}</pre></details></p>")


STYLE = ("body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse;margin:1em 0}"
         "td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}td:first-child{text-align:left}"
         "pre.wrap{white-space:pre-wrap;word-break:break-all;font-size:80%}"
         "figure{margin:1em 0}img{max-width:100%;height:auto}figcaption{max-width:800px;color:#333}")


def _tables(rep: dict, st: dict) -> list:
    """The sections after the plots (:mod:`fotogeo.tools.triangulate.report_tables`)."""
    return [rt.frames_section(rep["frames"]), rt.point_sigma_section(rep.get("point_sigma_by_role") or {}),
            rt.residuals_section(rep.get("residuals_by_size") or [], st["n_observations"]),
            rt.matching_section(rep.get("matching_summary"), rep.get("matching")),
            rt.mosaic_section(rep.get("mosaic"), rep.get("mosaic_resolution_m")),
            rt.timings_section(rep.get("timings_s") or {})]


def write_html(path, rep: dict, result, block, footprints) -> None:
    """``report.html`` (module docstring) from the report dict and the adjusted block."""
    st = rep["statistics"]
    summary = [("frames", st["n_frames"]), ("points", st["n_points"]), ("observations", st["n_observations"]),
               ("σ0", rt.fmt(rep["sigma0"])), ("image RMS (px)", rt.fmt(st["image_rms_px"])),
               ("blunders culled", st["n_blunders"]), ("control points rejected", st.get("n_control_rejected", 0))]
    accuracy = _accuracy_rows(st)
    fixed = [(f.get("parameter", ""), f.get("reason", "")) for f in rep["fixed_parameters"]]
    hist = (histogram(result), f"lengths |v| of the {int(np.count_nonzero(result.status == 'used'))} used image "
                               f"residuals, px")
    plots = [("Residual vectors per frame", residual_panels(result, block)), ("Residual histogram", hist),
             ("Control layout", control_layout(result, block, footprints))]
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>fotogeo triangulate</title><style>{STYLE}"
             "</style></head><body>",
             f"<h1>Aerial triangulation: {html.escape(str(rep.get('folder', '')))}</h1>", _crs_block(rep["crs"]),
             f"<p>{html.escape(rep['units'])}</p>", rt.table(summary, ("", "value")),
             "<h2>Accuracy (RMSE, m)</h2>",
             rt.table(accuracy, ("", "n", "X", "Y", "Z", "planimetric")) if accuracy else "<p>no control</p>",
             "<p>Check points and control placed by the images alone are errors in metres; the σ-weighted control "
             "residuals say only how far the control's σ let the points move.</p>",
             "<h2>Interior parameters held fixed</h2>", rt.table(fixed, ("parameter", "why")) if fixed else "<p>none</p>",
             rt.start_section(rep.get("start") or {}, rep.get("dropped_frames") or [])]
    parts += [f"<h2>{t}</h2><figure><img alt='{t}' src='data:image/png;base64,{_png(img)}'>"
              f"<figcaption>{caption}</figcaption></figure>" for t, (img, caption) in plots]
    parts += _tables(rep, st) + ["</body></html>"]
    from pathlib import Path
    Path(path).write_text("\n".join(parts), encoding="utf-8")
