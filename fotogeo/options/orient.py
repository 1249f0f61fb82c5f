"""The orientation tools' options (``fotogeo orient``, ``compare-models``, ``transfer``, ``targets``,
``rpc-bias``, ``points``)."""
from __future__ import annotations

from dataclasses import replace

from .shared import EXAGGERATION, ORIENTATION_MODELS, POLARITIES, RESAMPLING, SEED, SPREADS, YAML
from .table import Option, Table, field_options

#: where GCPs, their heights and the camera come from (orient, compare)
GCP = Table(
    Option("layer", "str", None, "Layer of a multi-layer GCP file", "Layer of a multi-layer GCP file."),
    Option("crs", "crs", None, "Map CRS of the GCPs (when their file or layer has none)",
           "Map CRS of the GCPs (needed for CSV, .points without #CRS, layers without CRS)."),
    Option("dem", "raster", None, "DEM for GCPs without height", "Heights for GCPs without a z value (bilinear)."),
    Option("height", "float", None, "Constant height for GCPs without height",
           "Constant height for GCPs without a z value."),
    Option("camera", "file", None, "Interior orientation YAML (collinearity)",
           "Interior orientation YAML (collinearity).", file_filter=YAML),
    *field_options("col", "row", "z", "role", "id"),
    groups={"fields": {n: f"{n}_field" for n in ("col", "row", "z", "role", "id")}},
)
ORIENT = Table(
    Option("model", "choice", "auto", "Model (auto = the simplest candidate the GCPs support, see the report)",
           "Model name, or auto (the default): every candidate the GCPs allow is fitted and the simplest within 5 % "
           "of the best check RMSE is kept.", choices=("auto",) + ORIENTATION_MODELS),
    Option("snooping", "bool", True, "Data snooping (flag blunders)", "Data snooping for blunders."),
    Option("remove_blunders", "bool", False, "Remove flagged blunders and refit", "Drop flagged blunders and refit."),
    Option("image_sigma", "float", None, "Image σ of the GCPs in px, the click precision (empty = estimated)",
           "A priori σ of the GCPs' image positions (click precision, px) for the blunder test [estimated from "
           "the residuals].", minimum=0.0, exclusive_minimum=True),
    Option("scan_pixel_um", "float", None, "Scan pixel size in µm (report residuals in mm on the photo)",
           "Scan pixel size (µm) to report residuals in mm on the photo.", minimum=0.0, advanced=True),
    EXAGGERATION,
    Option("resolution", "float", None, "Rectified pixel size (0 = the image's ground sample distance)",
           "Pixel size of the rectified raster [image GSD].", minimum=0.0, exclusive_minimum=True, automatic=0.0,
           advanced=True),
    replace(RESAMPLING, label="Rectification resampling", advanced=True),
)
#: how compare-models forms its control/check sets (fotogeo.orientation.comparison)
COMPARE_SETS = ("random", "roles")
COMPARE = Table(
    Option("models", "choices", None, "Models (none = the paper's and more)",
           "Comma-separated model names [the paper's models, its plain RFMs beside the regularised ones, image->ground "
           "RFMs, similarity, affine, poly2/3, collinearity].", choices=ORIENTATION_MODELS),
    Option("sets", "choice", "random", "Control/check sets: random draws, or the GCP file's role columns",
           "random: control points drawn per trial by --counts and --spreads; roles: the file's role column and "
           "every role_<label> column as fixed sets (the label's trailing _<number> dropped names the layout).",
           choices=COMPARE_SETS),
    Option("counts", "str", None, "Control points per set: N or N/M (empty = the paper's)",
           "Control-point counts per set: N (the rest are check points) or N/M (a spread pool of N+M points), for "
           "every model (40,20,10) or per model or name prefix (dlt=6,10,15 rfm=40,50,60; repeat the flag) "
           "[the paper's: 40,20,15,10,6 classical, 60,55,50,45,40 RFMs]. N = all points: the all-control row.",
           repeat=True),
    Option("spreads", "choices", SPREADS, "Spreads (layouts of random sets)", choices=SPREADS),
    Option("trials", "int", 5, "Seeded trials per random set (median RMS reported)",
           "Seeded trials per random set (median RMS reported).", minimum=1),
    replace(SEED, advanced=False),
    replace(ORIENT["scan_pixel_um"], label="Scan pixel size in µm (the table in mm on the photo)",
            help="Scan pixel size (µm): the table in mm on the photo, as the paper's (21 µm)."),
)
TRANSFER = Table(
    Option("search_radius", "int", 32, "Search radius around the approximation (px)",
           "Pixels around the approximation.", minimum=1),
    Option("half_window", "int", 10, "LSM half window h (window (2h+1)², px)", "LSM window (2h+1)².", minimum=2),
    *field_options("ref_col", "ref_row", "col", "row", "id"),
    groups={"ref_fields": ("ref_col_field", "ref_row_field"), "approx_fields": ("col_field", "row_field")},
)
TARGETS = Table(
    Option("half_window", "int", 12, "Half window (px)", minimum=4),
    Option("polarity", "choice", "auto", "Target polarity", choices=POLARITIES),
    *field_options("col", "row", "id"),
    groups={"approx_fields": ("col_field", "row_field")},
)
RPC_BIAS = Table(
    Option("method", "choice", "shift", "Correction (shift: >= 1 GCP; affine: >= 3)",
           "Image-space correction: shift (>= 1 GCP) or affine (>= 3 GCPs).", choices=("shift", "affine")),
    *GCP.only("layer", "crs", "dem", "height").values(),
    *field_options("col", "row", "z", "role", "id"),
    groups={"fields": {n: f"{n}_field" for n in ("col", "row", "z", "role", "id")}},
)
_SOURCE_RASTER = Option("raster", "raster", None, "Source raster, if georeferenced (empty = unreferenced convention)",
                        "Source raster, when the points are in its map coordinates.")
POINTS_TO_LAYER = Table(_SOURCE_RASTER, Option("crs", "crs", None, "CRS of the map coordinates (empty = the file's #CRS)",
                                               "CRS of the map coordinates [the file's #CRS]."))
LAYER_TO_POINTS = Table(_SOURCE_RASTER)
