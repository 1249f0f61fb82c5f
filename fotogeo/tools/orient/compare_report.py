"""The comparison laid out like Table 1 of Öztürk, Karşlı & Dihkan: CSV, Markdown, HTML and error-vector plots.

One table per layout (spread): a model's rows follow each other, its name on the first; columns
GCP | CP | mx my at the control points (GCP) | mx my at the check points (CP) | min, median, max of
the check-point error lengths; in mm on the photo when a scan pixel size was given, else in pixels.
"""
from __future__ import annotations

import csv
import html
import importlib.util

import numpy as np

from ...errors import InputError
from ...orientation.comparison import STAT_KEYS

#: the model names as the paper's table prints them (the others print as they are)
PAPER_NAMES = {"affine-height": "Affine with height (paper: Afin)", "bilinear": "Bilinear (Bi-lineer)",
               "projective": "Projective (Projektive)", "dlt": "DLT",
               "rfm-plain": "RFM ground→image, paper's plain LS (Arazide Resme Geçiş)",
               "rfm-common-plain": "RFM B=D, paper's plain LS", "rfm-poly-plain": "RFM B=D=1, paper's plain LS",
               "rfm-plain-i2g": "RFM image→ground, paper's plain LS (Resimden Araziye Geçiş)",
               "rfm": "RFM ground→image, regularised", "rfm-common": "RFM B=D, regularised",
               "rfm-poly": "RFM B=D=1, regularised", "rfm-i2g": "RFM image→ground, regularised"}
COLUMNS = ("GCP mx", "GCP my", "CP mx", "CP my", "CP min", "CP median", "CP max")
_STATS = ("control_rms_x", "control_rms_y", "check_rms_x", "check_rms_y", "check_min", "check_median", "check_max")


def unit_of(rows) -> str:
    """``mm`` when the rows carry mm statistics, else ``px``."""
    return "mm" if any("check_rms_x_mm" in r or "control_rms_x_mm" in r for r in rows) else "px"


def layouts(rows) -> dict:
    """``{layout: rows}`` in first-seen order; rows without a layout (notes) go under ``""``."""
    out: dict = {}
    for r in rows:
        out.setdefault(r.get("spread") or "", []).append(r)
    return out


def cells(row, unit: str) -> list[str]:
    """The GCP, CP counts and the statistics of ``row`` as text (3 decimals in mm, 3 in px)."""
    def f(v):
        return "" if v is None else f"{v:.3f}"
    head = [str(row.get("n_control", "")), str(row.get("n_check", ""))]
    return head + [f(row.get(f"{k}_{unit}")) for k in _STATS]


def write_csv(rows, path) -> None:
    """Every row: model, layout, set, counts, statistics in px (and mm), trials, note."""
    keys = ["model", "spread", "set", "n_control", "n_check"]
    keys += [f"{k}_{u}" for u in ("px", "mm") for k in STAT_KEYS if any(f"{k}_{u}" in r for r in rows)]
    keys += ["trials", "note"]
    with open(path, "w", newline="") as fh:
        wr = csv.DictWriter(fh, keys, extrasaction="ignore")
        wr.writeheader()
        wr.writerows(rows)


def markdown_table(rows) -> str:
    """The Table-1 layout in Markdown: one section per layout."""
    unit = unit_of(rows)
    out = []
    for layout, group in layouts(rows).items():
        out.append(f"### {layout or 'not fitted'} ({unit})\n")
        out.append("| model | GCP | CP | " + " | ".join(COLUMNS) + " | note |")
        out.append("|---|---:|---:|" + "---:|" * len(COLUMNS) + "---|")
        last = None
        for r in group:
            name = "" if r["model"] == last else PAPER_NAMES.get(r["model"], r["model"])
            last = r["model"]
            out.append(f"| {name} | " + " | ".join(cells(r, unit)) + f" | {r.get('note', '')} |")
        out.append("")
    return "\n".join(out)


def html_table(rows, title: str = "Orientation models compared") -> str:
    """The Table-1 layout as a standalone HTML page (one table per layout)."""
    unit = unit_of(rows)
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
             "<style>table{border-collapse:collapse;margin-bottom:2em}td,th{border:1px solid #999;padding:2px 6px}"
             "td.n{text-align:right}</style></head><body>", f"<h1>{html.escape(title)}</h1>"]
    for layout, group in layouts(rows).items():
        parts.append(f"<h2>{html.escape(layout or 'not fitted')} ({unit})</h2><table>")
        parts.append("<tr><th rowspan=2>model</th><th rowspan=2>GCP</th><th rowspan=2>CP</th>"
                     f"<th colspan=2>GCP ({unit})</th><th colspan=5>CP ({unit})</th><th rowspan=2>note</th></tr>"
                     "<tr><th>mx</th><th>my</th><th>mx</th><th>my</th><th>min</th><th>median</th><th>max</th></tr>")
        for model in dict.fromkeys(r["model"] for r in group):
            mine = [r for r in group if r["model"] == model]
            for i, r in enumerate(mine):
                name = (f"<td rowspan={len(mine)}>{html.escape(PAPER_NAMES.get(model, model))}</td>" if i == 0
                        else "")
                tds = "".join(f"<td class=n>{c}</td>" for c in cells(r, unit))
                parts.append(f"<tr>{name}{tds}<td>{html.escape(r.get('note', ''))}</td></tr>")
        parts.append("</table>")
    parts.append("</body></html>")
    return "\n".join(parts)


def require_plotting() -> None:
    """Refuse plots before any file is written when matplotlib (the ``plots`` extra) is not installed."""
    if importlib.util.find_spec("matplotlib") is None:
        raise InputError("plots (--plots) need matplotlib, which is not installed: pip install 'fotogeo[plots]' "
                         "(or leave out plots)")


def plot_name(model: str, layout: str) -> str:
    """File name of the error-vector plot of ``model`` in ``layout``."""
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in f"{model}_{layout}")
    return f"{safe}.png"


def plot_vectors(rows, model: str, layout: str, path, *, width: float, height: float) -> bool:
    """One PNG of ``model``'s error vectors in ``layout``: a panel per set (its first trial), control
    points blue, check points red, vectors exaggerated by one factor for the whole figure (the
    paper's Figures 5 and 6). False when there is nothing to draw."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    mine = [r for r in rows if r["model"] == model and r.get("spread") == layout and r.get("vectors")]
    if not mine:
        return False
    longest = max(float(np.nanmax(np.hypot(*r["vectors"]["error"].T), initial=0)) for r in mine)
    k = _exaggeration(longest, max(width, height))
    fig, axes = plt.subplots(1, len(mine), figsize=(2.4 * len(mine) + 0.6, 4.2), squeeze=False)
    for ax, r in zip(axes[0], mine):
        v = r["vectors"]
        for role, colour in (("control", "tab:blue"), ("check", "tab:red")):
            sel = v["role"] == role
            p, e = v["pixel"][sel], v["error"][sel]
            ax.plot(p[:, 0], p[:, 1], ".", color=colour, ms=3)
            ax.quiver(p[:, 0], p[:, 1], e[:, 0] * k, e[:, 1] * k, color=colour, angles="xy", scale_units="xy",
                      scale=1, width=0.006)
        ax.set_xlim(0, width), ax.set_ylim(height, 0), ax.set_aspect("equal")
        ax.set_title(f"{r['n_control']}/{r['n_check']}", fontsize=9)
        ax.tick_params(labelsize=6)
    fig.suptitle(f"{model}, {layout}: errors x{k:g} (blue control, red check)", fontsize=9)
    fig.savefig(path, dpi=110, format="png", bbox_inches="tight")
    plt.close(fig)
    return True


def _exaggeration(longest: float, size: float) -> float:
    """A 1-2-5 factor drawing the longest vector at about a tenth of the image size."""
    if not np.isfinite(longest) or longest <= 0:
        return 1.0
    raw = 0.1 * size / longest
    exp = np.floor(np.log10(raw))
    step = max(s for s in (1, 2, 5) if s * 10 ** exp <= raw) if raw >= 10 ** exp else 1
    return float(step * 10 ** exp)
