"""The model-comparison tool: GCPs (path) → Table 1 of Öztürk, Karşlı & Dihkan for every model × set × layout.

Sets (:mod:`fotogeo.orientation.comparison`): ``sets="random"`` draws control points per trial
by count and spread; ``sets="roles"`` takes the GCP file's role column and every column named
``role_<label>`` (e.g. ``role_homogeneous_20``) as fixed sets. Outputs (:mod:`.compare_report`):
CSV, Markdown, HTML in the paper's layout and a folder of error-vector plots per model and layout.

With a camera, GCP pixels read on a copy of the image of another size or turned are refused naming it, as ``orient``
refuses them (:func:`fotogeo.tools.common.checks.copy_check`): the free-scale models would absorb the copy and fill
the table with plausible wrong rows.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError, OutputError
from ...io.camera import load_camera
from ...io.gcps import inside_image, read_gcps
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, open_raster
from ...models import get_model
from ...orientation.comparison import compare, parse_counts
from . import compare_report as report
from ..common.boundary import OUTPUTS, tool
from ..common.checks import camera_fit, check_camera_size, check_gcp_crs, inside_fitted

#: the default models: the paper's (affine with height, bilinear, projective, DLT, the RFMs solved as the
#: paper did and regularised, both directions) and fotogeo's other 2-D models and collinearity
DEFAULT_MODELS = ("similarity", "affine", "projective", "poly2", "poly3", "affine-height", "bilinear", "dlt",
                  "rfm-plain", "rfm-common-plain", "rfm-poly-plain", "rfm-plain-i2g", "rfm", "rfm-common", "rfm-poly",
                  "rfm-i2g", "collinearity")


@tool("COMPARE", "GCP", rasters={"image": None, "dem": None}, outputs=OUTPUTS + ("html", "plots"))
def compare_models(image, gcps, *, models=None, counts=None, sets: str = "random",
                   spreads=("homogeneous", "heterogeneous"), trials: int = 5, seed: int = 0, scan_pixel_um=None,
                   table=None, markdown=None, html=None, plots=None, dem=None, height=None, crs=None, layer=None,
                   fields=None, camera=None, overwrite: bool = False, progress=None) -> list[dict]:
    """Every model × set × layout on one GCP file (module docstring); returns the rows.

    ``counts``: None (the paper's 40 … 6 for classical models, 60 … 40 for RFMs), integers, or
    text ``"[model=]N[/M],..."`` (:func:`~fotogeo.orientation.comparison.parse_counts`).
    ``scan_pixel_um`` adds mm on the photo. ``plots``: a folder for ``<model>_<layout>.png``.
    """
    info = open_raster(image, "image")
    if sets == "random":
        parse_counts(counts)  # a bad counts text is refused before any file is read
    for p in (table, markdown, html):
        if p:
            check_output(p, [image, gcps], overwrite, "table")
    if plots and Path(plots).exists() and not Path(plots).is_dir():
        raise InputError(f"plots {str(plots)!r} is a file; give a folder for the error-vector plots")
    if plots:
        report.require_plotting()
    g = read_gcps(gcps, layer=layer, crs=crs, raster=image if info.georeferenced else None, dem=dem,
                  height=height, **(fields or {}))
    check_gcp_crs(g, gcps)
    camera = load_camera(camera)
    check_camera_size(camera, info.width, info.height, image)
    needed = (f"{gcps}", get_model("similarity").min_points, "the simplest model (similarity)")
    g, _ = (inside_image(g, info.width, info.height, *needed) if camera is None else
            inside_fitted(g, info.width, info.height, *needed, camera_fit(camera)))
    _check_partial_heights(g, gcps)
    role_sets = _role_sets(g, gcps) if sets == "roles" else None
    chosen = bool(models)
    models = list(models or DEFAULT_MODELS)
    usable = [m for m in models if get_model(m).src_dims == 2 or g.has_heights]
    _enough_points(usable, chosen, len(g.pixel), counts if sets == "random" else None, gcps)
    scale_mm = scan_pixel_um / 1000.0 if scan_pixel_um else None
    rows = compare(usable, g.ground, g.pixel, counts=counts, spreads=spreads, trials=trials, seed=seed, camera=camera,
                   role_sets=role_sets, scale_mm=scale_mm, progress=progress)
    for m in models:
        if m not in usable:
            rows.append({"model": m, "note": "3-D model: GCPs have no heights (give a height field, DEM or constant)"})
    _write(rows, table, markdown, html, plots, overwrite, info)
    return [{k: v for k, v in r.items() if k != "vectors"} for r in rows]


def _enough_points(models, chosen: bool, n: int, counts, gcps) -> None:
    """Refuse a GCP file with fewer points than a chosen model needs (or than every default model needs), and
    ``counts`` asking for more control + check points than the file holds."""
    from ...orientation.comparison import FAMILY_COUNTS
    short = [(m, get_model(m).min_points) for m in models if get_model(m).min_points > n]
    if short and (chosen or len(short) == len(models)):
        need = ", ".join(f"{m} needs {k}" for m, k in short[:6])
        raise InputError(f"GCP file {str(gcps)!r} holds {n} point(s): {need}; give more GCPs"
                         + (" or leave those out of models" if chosen else ""), option="models" if chosen else None)
    if counts is None:
        return
    given = {k: v for k, v in parse_counts(counts).items() if v is not FAMILY_COUNTS.get(k)}
    over = [f"{c}/{k}" if k is not None else str(c) for items in given.values() for c, k in items if c + (k or 0) > n]
    if over:
        raise InputError(f"counts {', '.join(over[:6])} ask for more control (+ check) points than the {n} of GCP file "
                         f"{str(gcps)!r}; give counts up to {n}", option="counts")


def _check_partial_heights(g, gcps) -> None:
    """Refuse GCPs of which some have a height and some not: the 3-D models would be left out for all of them
    (a table without its DLT/RFM rows, "GCPs have no heights") because of one empty cell."""
    missing = ~np.isfinite(g.ground[:, 2])
    if missing.any() and not missing.all():
        ids = ", ".join(g.ids[missing][:10]) + (" …" if missing.sum() > 10 else "")
        raise InputError(f"GCP file {str(gcps)!r}: GCP(s) {ids} have no height while the other "
                         f"{int((~missing).sum())} have one; fill their z field, or give dem (a DEM their heights "
                         "are read from) or a constant height", option="dem")


def _role_sets(g, gcps) -> dict:
    """The fixed sets of ``sets="roles"``: every ``role_<label>`` column, and the role column unless it
    is all control with such columns present (it then repeats the all-control row)."""
    found = dict(g.role_sets)
    if not found or (g.role == "check").any():
        found = {"file": g.role, **found}
    empty = [k for k, v in found.items() if not (v == "control").any()]
    if empty:
        raise InputError(f"GCP file {str(gcps)!r}: role column(s) {', '.join(empty)} mark no control point; set "
                         "role to 'control' for the points of each set, or use sets='random'")
    return found


def _write(rows, table, markdown, html, plots, overwrite, info) -> None:
    with AtomicOutputs(overwrite) as out:
        if table:
            report.write_csv(rows, out.temp(table))
        if markdown:
            Path(out.temp(markdown)).write_text(report.markdown_table(rows))
        if html:
            Path(out.temp(html)).write_text(report.html_table(rows))
        if plots:
            Path(plots).mkdir(parents=True, exist_ok=True)
            for model in dict.fromkeys(r["model"] for r in rows):
                for layout in dict.fromkeys(r.get("spread") for r in rows if r["model"] == model and r.get("spread")):
                    final = Path(plots) / report.plot_name(model, layout)
                    if not any(r.get("vectors") for r in rows if r["model"] == model and r.get("spread") == layout):
                        continue
                    if final.exists() and not overwrite:
                        raise OutputError(f"plot {str(final)!r} exists; pass overwrite=True or give another folder",
                                         option="overwrite")
                    report.plot_vectors(rows, model, layout, out.temp(final), width=info.width, height=info.height)
        out.commit()


def markdown_table(rows) -> str:
    """The rows in the paper's layout (Markdown), as the command line prints them."""
    return report.markdown_table(rows)
