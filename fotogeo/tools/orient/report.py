"""The readable form of ``orient``'s report: ``report.html`` beside (or instead of) ``report.json``.

One page a GIS user reads without a JSON viewer: the model (and, for ``auto``, every candidate with
the error it was compared on and why the chosen one won), control and check RMS per role, the
warnings and blunder findings, and one row per GCP — role, pixel, residual in pixels and in ground
units, its flag. The report dict is :func:`fotogeo.tools.orient.tool.orient`'s, unchanged.
"""
from __future__ import annotations

import html
from pathlib import Path

STYLE = ("body{font-family:sans-serif;margin:2em;max-width:1000px}table{border-collapse:collapse;margin:1em 0}"
         "td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}td:first-child{text-align:left}"
         "tr.check td{color:#005ac8}tr.flag td{color:#dc0000}p.note{color:#333}")


def _fmt(x, digits: int = 2) -> str:
    return f"{x:.{digits}f}" if isinstance(x, (int, float)) and x == x else "–"


def _table(head, rows, classes=None) -> str:
    th = "".join(f"<th>{html.escape(str(h))}</th>" for h in head)
    body = "".join(f"<tr{f' class={chr(39)}{c}{chr(39)}' if c else ''}>"
                   + "".join(f"<td>{html.escape(str(v))}</td>" for v in r) + "</tr>"
                   for r, c in zip(rows, classes or [""] * len(rows)))
    return f"<table><tr>{th}</tr>{body}</table>"


def _roles(rep: dict) -> str:
    rows = [(role, s["n"], *(_fmt(s.get(k)) for k in ("rms_x_px", "rms_y_px", "rms_xy_px", "median_px", "max_px")))
            for role in ("control", "check") for s in [rep.get(role) or {}] if s.get("n")]
    return _table(("", "n", "RMS x px", "RMS y px", "RMS px", "median px", "max px"), rows) if rows else "<p>–</p>"


def _selection(rep: dict) -> str:
    sel = rep.get("model_selection")
    if not sel:
        return ""
    key = sel.get("compared", "")
    rows = [(c["model"], c.get("n_params", "–"), _fmt(c.get("control_rmse_px")), _fmt(c.get(key)),
             "yes" if c.get("ill_posed") else "", c.get("note", "")[:80]) for c in sel.get("candidates", [])]
    classes = ["check" if c["model"] == sel.get("chosen") else "" for c in sel.get("candidates", [])]
    return ("<h2>Model choice (auto)</h2>" + _table(("model", "parameters", "control RMS px", key, "ill-posed", "note"),
                                                    rows, classes)
            + f"<p class='note'>{html.escape(str(sel.get('because', '')))}</p>")


def _points(rep: dict) -> str:
    flagged = {str(f.get("id")) for f in rep.get("snooping") or []}
    rows, classes = [], []
    for p in rep.get("points", []):
        d = (p["dx_px"] ** 2 + p["dy_px"] ** 2) ** 0.5
        rows.append((p["id"], p["role"], _fmt(p["col"], 1), _fmt(p["row"], 1), _fmt(p["dx_px"]), _fmt(p["dy_px"]),
                     _fmt(d), _fmt(p["dx_ground"]), _fmt(p["dy_ground"]), "blunder?" if str(p["id"]) in flagged else ""))
        classes.append("flag" if str(p["id"]) in flagged else ("check" if p["role"] == "check" else ""))
    return _table(("id", "role", "col", "row", "dx px", "dy px", "|d| px", "dx ground", "dy ground", "flag"),
                  rows, classes)


def write_report_html(path, rep: dict) -> None:
    """``rep`` (orient's report dict) as one readable HTML page (module docstring)."""
    notes = [*(f"GCP {s['id']} skipped: {s['reason']} (col {s['col']:.1f}, row {s['row']:.1f})"
               for s in rep.get("skipped") or []),
             *(rep.get("warnings") or []), *(rep.get("hints") or []),
             *(f.get("reason", "") for f in rep.get("snooping") or [])]
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>fotogeo orient</title><style>{STYLE}</style>"
             "</head><body>", f"<h1>Orientation of {html.escape(Path(str(rep.get('image', ''))).name)}</h1>",
             f"<p>model <b>{html.escape(str(rep.get('model_name', '')))}</b>, {rep.get('n_gcps', 0)} GCPs, CRS "
             f"{html.escape(str(rep.get('crs', ''))[:80])}; {html.escape(str(rep.get('units', '')))}</p>",
             "<h2>Residuals per role</h2>", _roles(rep), _selection(rep)]
    if notes:
        parts.append("<h2>Warnings and flags</h2><ul>" + "".join(f"<li>{html.escape(str(n))}</li>" for n in notes)
                     + "</ul>")
    parts += ["<h2>GCPs</h2><p class='note'>residual = the model's image position − the measured pixel; "
              "check points blue, flagged points red</p>", _points(rep), "</body></html>"]
    Path(path).write_text("\n".join(parts), encoding="utf-8")
