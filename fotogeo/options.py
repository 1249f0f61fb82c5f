"""Every tool option, declared once: the command line and the QGIS parameters are generated from here
(the mechanism, :class:`Option` and :class:`Table`, is in :mod:`fotogeo.option_table`).

An :class:`Option` is one keyword argument of a tool (``fotogeo/tools/<tool>.py``): its name,
kind, default, valid range or choices, the command-line help and flag, the QGIS parameter
label and name, and whether QGIS shows it under *Advanced*. A :class:`Table` is the ordered
set of options of one tool. From a table,

- ``fotogeo.cli.common.options_from(table)`` makes the click options of the ``fotogeo``
  command (flag ``--name-with-dashes``, default shown in ``--help``);
- ``processing_provider/algorithms/base.py`` adds the QGIS Processing parameters
  (``NAME`` in upper case) and reads them back into the tool's keyword arguments;
- :class:`RegisterOptions` (the registration settings) is a frozen dataclass built from
  :data:`REGISTER`, whose ``validate()`` checks types, ranges and choices against the table.

Conventions of the QGIS side, where a number or an enum cannot be empty: an option whose
default is ``None`` is an optional parameter (empty = ``None``), unless it has an
``automatic`` value — the number standing for ``None`` ("0 = automatic") — or a
``none_choice`` — the enum entry, listed first, standing for ``None`` ("default").

The choice lists (:data:`DETECTORS`, :data:`CONTRASTS`, :data:`RESAMPLINGS`,
:data:`PLANAR_MODELS`, :data:`TERRAIN_MODELS`, :data:`ORIENTATION_MODELS`, ...) live here
and the array and tool modules import them, so there is one list of each. This module
imports the standard library only: the QGIS plugin reads it when it loads, before it knows
whether numpy and the other dependencies are installed.
"""
from __future__ import annotations

from dataclasses import field, fields, make_dataclass, replace

from .option_table import KINDS, Option, Table, field_options, in_labels  # noqa: F401 (re-exported)

DETECTORS = ("surf", "sift")
CONTRASTS = ("adaptive", "equalize", "linear")
RESAMPLINGS = ("nearest", "bilinear", "cubic")
PLANAR_MODELS = ("projective", "affine", "similarity")
TERRAIN_MODELS = ("auto", "dlt", "rfm", "rfm-common", "rfm-poly", "collinearity")
#: every model of :data:`fotogeo.models.MODELS`, sorted (``fotogeo.models`` checks it on import)
ORIENTATION_MODELS = ("affine", "affine-height", "bilinear", "collinearity", "dlt", "poly1", "poly2", "poly3",
                      "poly3d-1", "poly3d-2", "poly3d-3", "projective", "rfm", "rfm-common", "rfm-common-i2g",
                      "rfm-common-plain", "rfm-i2g", "rfm-plain", "rfm-plain-i2g", "rfm-poly", "rfm-poly-i2g",
                      "rfm-poly-plain", "similarity")
#: tie-point refinement: ``auto`` = ``lsm`` for the 2-D registration, ``none`` with a DEM
#: (fotogeo.tools.register_points.refine_mode)
REFINES = ("none", "lsm", "auto")
POLARITIES = ("auto", "bright", "dark")
SPREADS = ("homogeneous", "heterogeneous")
#: interior parameters a bundle adjustment may estimate (self-calibration; fotogeo.orientation.bundle_jacobian)
INTERIOR_PARAMETERS = ("f", "ppx", "ppy", "k1", "k2", "k3", "p1", "p2")
#: Ebner's (1976) 12 additional parameters (fotogeo.orientation.bundle_jacobian); "ebner" names all of them
EBNER_PARAMETERS = tuple(f"b{i}" for i in range(1, 13))
SELF_CALIBRATION = INTERIOR_PARAMETERS + EBNER_PARAMETERS + ("ebner",)
#: what triangulate does with a frame the block does not determine
UNDETERMINED = ("fail", "drop")
#: height references a DEM may be given in (fotogeo.geometry.vertical); auto = what its CRS states
DEM_HEIGHTS = ("auto", "ellipsoid", "geoid")
#: image representations of the area-based co-registration (fotogeo.coreg.representation)
COREG_REPRESENTATIONS = ("orientation", "gradient", "rank", "intensity")

# -- shared options -----------------------------------------------------------------------
SEED = Option("seed", "int", 0, "Random seed", minimum=0, advanced=True)
DETECTOR = Option("detector", "choice", "surf", "Keypoint detector", choices=DETECTORS)
MAX_KEYPOINTS = Option("max_keypoints", "int", 8000, "Maximum keypoints per image", "Per image, spatially balanced.",
                       minimum=10, advanced=True)
RATIO = Option("ratio", "float", 0.8, "Ratio test (nearest / second-nearest distance)",
               "Nearest/second-nearest ratio test.", minimum=0.05, maximum=1.0)
RANSAC_THRESHOLD = Option("ransac_threshold", "float", 3.0, "RANSAC threshold (reference pixels)",
                          "RANSAC inlier threshold in reference pixels.", minimum=0.01)
#: error vectors drawn k times their length: ``auto`` (the default) or a number (see fotogeo.io.vector)
EXAGGERATION = Option("exaggeration", "str", "auto", "Error vector exaggeration (auto or a number)",
                      "Error vectors drawn this many times their length: 'auto' (a 1-2-5 factor making them "
                      "readable, see the report) or a number.", minimum=0.0, exclusive_minimum=True, choices=("auto",),
                      advanced=True)
RESAMPLING = Option("resampling", "choice", "nearest", "Resampling", choices=RESAMPLINGS)
#: the planimetric σ raster beside each orthophoto (``fotogeo ortho`` and ``triangulate --orthorectify``) and the
#: DEM's height σ it adds (fotogeo.tools.ortho_products)
UNCERTAINTY = Option("uncertainty", "bool", False,
                     "Uncertainty raster: predicted planimetric σ (m) per cell (<orthophoto>_sigma.tif)",
                     "Also write <orthophoto>_sigma.tif: the predicted planimetric sigma (m) of every cell, from the "
                     "covariance in triangulate's report.json beside --eo and the DEM's sigma (--dem-sigma).")
DEM_SIGMA = Option("dem_sigma", "float", None, "Height σ of the DEM for the uncertainty, m (0 = half the DEM's cell)",
                   "Height sigma of the DEM (m) for --uncertainty [half the DEM's cell].", minimum=0.0,
                   exclusive_minimum=True, automatic=0.0, advanced=True)
YAML = "YAML (*.yaml *.yml)"
#: where Dask tasks run: register-batch's scenes, triangulate's pairs (fotogeo.tools.batch._cluster)
SCHEDULER = Option("scheduler", "str", None, "Dask scheduler address (empty = a local cluster)",
                   "Address of a running Dask scheduler, e.g. tcp://host:8786 [a local cluster on this machine].")
WORKERS = Option("workers", "int", None, "Local Dask workers (0 = one per CPU)", "Workers of the local cluster [one "
                 "per CPU].", minimum=0, automatic=0)

# -- the tools ------------------------------------------------------------------------------
#: registration settings, in the field order of :class:`RegisterOptions` (and of the report's "options")
REGISTER = Table(
    DETECTOR, MAX_KEYPOINTS,
    Option("hessian_threshold", "float", None, "SURF Hessian threshold (0 = automatic)",
           "SURF detector threshold (on 0..255 fused images).", minimum=0.0, automatic=0.0, advanced=True),
    RATIO,
    Option("mutual", "bool", True, "Keep only mutual nearest neighbours", "Keep only mutual nearest neighbours.",
           advanced=True),
    Option("model", "choice", None, "Geometric model (default: projective; with a DEM: auto)",
           "projective (default), affine, similarity; with --dem: auto (default), dlt, rfm, rfm-common, rfm-poly, "
           "collinearity.", choices=PLANAR_MODELS + TERRAIN_MODELS, none_choice="default"),
    RANSAC_THRESHOLD,
    Option("check_fraction", "float", 0.3, "Fraction of inliers held out as check points",
           "Fraction of inliers held out as check points.", minimum=0.0, maximum=0.89),
    SEED, RESAMPLING,
    Option("resolution", "float", None, "Output pixel size in output CRS units (0 = the reference's)",
           "Output pixel size in output CRS units [the reference's].", minimum=0.0, exclusive_minimum=True,
           automatic=0.0),
    Option("dst_crs", "crs", "auto", "Output CRS (empty = the reference's if projected, else the UTM zone of its centre)",
           "Output CRS: 'auto' = 'reference' if the reference's CRS is projected, else 'utm'; 'reference'; 'utm' "
           "(UTM zone of the reference centre, the source paper's rule); or EPSG:xxxx, WKT, PROJ.", flag="--crs",
           param="CRS"),
    Option("max_match_pixels", "int", 16_000_000, "Decimate images larger than this many pixels for matching",
           "Images larger than this are decimated for matching (not for resampling).", minimum=10_000, advanced=True),
    EXAGGERATION,
    Option("cog", "bool", False, "Write a Cloud Optimized GeoTIFF (COG)",
           "Write the registered raster as a Cloud Optimized GeoTIFF (tiled, overviews; GDAL's COG driver).",
           advanced=True),
    Option("contrast", "choice", "adaptive", "Contrast of the fused images for matching",
           "Contrast of the fused images for matching (adaptive = equalize + CLAHE).", choices=CONTRASTS,
           advanced=True),
    Option("refine", "choice", "auto", "Refine tie points before the fit (lsm = least-squares matching; "
           "auto = lsm without a DEM)",
           "Refine tie points by least-squares matching before the fit: auto = lsm for the 2-D registration, "
           "none with --dem.", choices=REFINES, advanced=True),
    Option("reference_nodata", "float", None, "Reference nodata value (empty = the file's)",
           "Nodata value of the reference (overrides the file's).", advanced=True),
    Option("target_nodata", "float", None, "Target nodata value (empty = the file's)",
           "Nodata value of the target (overrides the file's).", advanced=True),
    Option("reference_bands", "str", None, "Reference bands to match, e.g. 1,2,3 (empty = all)",
           "Bands of the reference fused for matching, 1-based as gdal_translate -b, e.g. 1,2,3 [all]; "
           "empty or constant bands are left out with a warning.", advanced=True),
    Option("target_bands", "str", None, "Target bands to match, e.g. 4,3,2 (empty = all)",
           "Bands of the target fused for matching, e.g. 4,3,2 [all]; the registered raster keeps every band.",
           advanced=True),
    Option("local", "bool", False, "Local co-registration on top of the model (displacement field)",
           "Remove residual local distortions: a grid of matching windows between the reference and the "
           "registered raster, a smooth displacement field through the reliable ones (fotogeo coreg), applied "
           "before writing; window shifts in OUT.gpkg layer local_windows, the field in --field."),
    Option("local_smoothing", "float", 1.0, "Local field smoothing (0 = through every window; larger = stiffer)",
           "Smoothing of the --local field (0 = through every reliable window; larger = stiffer).", minimum=0.0,
           advanced=True),
    Option("local_grid_spacing", "int", 64, "Local window grid spacing (output pixels)",
           "Grid spacing of the --local windows (output pixels).", minimum=4, advanced=True),
    Option("local_window", "int", 128, "Local matching window size (output pixels, even)",
           "Size of the --local matching windows (output pixels, even).", minimum=16, maximum=4096, advanced=True),
    Option("area_fallback", "bool", True, "Match a grid of windows when feature matching fails",
           "When feature matching finds too few matches or inliers and the target is georeferenced within a few "
           "pixels, match a grid of windows (area-based, robust to seasonal change) for the tie points instead; "
           "the report says so.", advanced=True),
)
#: registration inputs besides the two images: terrain-aware registration
REGISTER_TERRAIN = Table(
    Option("dem", "raster", None, "DEM (terrain-aware registration: 3-D model, orthorectified output)",
           "DEM: terrain-aware registration with a 3-D model and an orthorectified output."),
    Option("camera", "file", None, "Interior orientation YAML of the target camera (model collinearity)",
           "Interior orientation YAML of the target's camera (for --model collinearity).", file_filter=YAML),
)
#: detect and match only (``match_images``), with the registration's option declarations
MATCH = REGISTER.only("detector", "max_keypoints", "ratio", "ransac_threshold", "reference_bands", "target_bands",
                      max_keypoints={"advanced": False})
FUSE = Table(
    Option("stretch", "bool", True, "Stretch to 8 bit (1..255, 0 = nodata)",
           "uint8 0..255 robust stretch, or float32 component values."),
    replace(SEED, label="Random seed (pixel sample)"),
)
DEMO = Table(
    Option("seed", "int", 7, "Seed of the generated scene", "Seed of the generated scene.", minimum=0),
    DETECTOR,
)
#: where GCPs, their heights and the camera come from (orient, compare)
GCP = Table(
    Option("layer", "str", None, "Layer of a multi-layer GCP file", "Layer of a multi-layer GCP file."),
    Option("crs", "crs", None, "Map CRS of the GCPs (for CSV, .points without #CRS, layers without CRS)",
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
    Option("models", "choices", None, "Models (none = the paper's, both RFM solutions and directions, and more)",
           "Comma-separated model names [the paper's models, its plain RFMs beside the regularised ones, image->ground "
           "RFMs, similarity, affine, poly2/3, collinearity].", choices=ORIENTATION_MODELS),
    Option("sets", "choice", "random", "Control/check sets: random draws, or the GCP file's role columns",
           "random: control points drawn per trial by --counts and --spreads; roles: the file's role column and "
           "every role_<label> column as fixed sets (the label's trailing _<number> dropped names the layout).",
           choices=COMPARE_SETS),
    Option("counts", "str", None, "Control points per set: N or N/M (control/check), per model as dlt=6,10;rfm=40,50 "
           "(empty = the paper's)",
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
#: aerial triangulation (``fotogeo triangulate``, fotogeo.tools.triangulate)
TRIANGULATE = Table(
    Option("crs", "crs", None, "Map CRS of the block (empty = the GCPs', else the orthophotos', the DEM's or the "
           "GPS's UTM zone)", "Projected map CRS of the block [the GCPs' CRS, else the reference orthophoto's, the "
           "DEM's, or the UTM zone of the images' GPS]."),
    Option("gcp_crs", "crs", None, "CRS of the GCP file's ground X, Y (empty = its own, else the map CRS)",
           "CRS of the GCPs' ground x, y when the file carries none (CSV) or to override it [the map CRS]."),
    Option("check_points", "str", None, "GCP names used as check points (comma-separated)",
           "Comma-separated GCP names held out as check points."),
    Option("self_calibration", "choices", None, "Interior parameters to estimate (none = fixed camera)",
           "Comma-separated interior parameters to estimate (ebner: Ebner's 12 additional parameters b1-b12) "
           "[none].", choices=SELF_CALIBRATION),
    Option("control_sigma_xy", "float", 0.05, "σ of GCP X and Y (m)", "σ of the GCPs' X, Y (m).", minimum=0.0,
           exclusive_minimum=True),
    Option("control_sigma_z", "float", 0.05, "σ of GCP heights (m)", "σ of the GCPs' Z (m).", minimum=0.0,
           exclusive_minimum=True),
    Option("image_sigma", "float", 1.0, "A priori σ of image measurements (px)",
           "A priori σ of the image measurements (px); the report's σ0 is relative to it.", minimum=0.0,
           exclusive_minimum=True, advanced=True),
    Option("eo_sigma_position", "float", None, "σ of the approximate projection centres (m; empty = free)",
           "σ of the approximate projection centres, e.g. GNSS (m) [free].", minimum=0.0, exclusive_minimum=True,
           advanced=True),
    Option("eo_sigma_angle", "float", None, "σ of the approximate angles (°; empty = free)",
           "σ of the approximate ω, φ, κ, e.g. INS (degrees) [free].", minimum=0.0, exclusive_minimum=True,
           advanced=True),
    Option("snooping", "bool", True, "Data snooping (cull blunders and re-solve)", "Data snooping for blunders."),
    Option("max_correlation", "float", 0.999, "Hold fixed interior parameters correlated above",
           "Interior parameters whose multiple correlation exceeds this are held fixed.", minimum=0.5, maximum=1.0,
           advanced=True),
    Option("check_fraction", "float", None, "Fraction of the control held out as check points (empty = 0.2 "
           "with ≥ 10 points in 2+ frames)",
           "Fraction of the control points held out as check points, spread over the block (seeded) [0.2 when "
           "no check points are named and >= 10 control points are measured in two frames or more, else 0].",
           minimum=0.0, maximum=0.9),
    replace(SEED, label="Random seed (check-point hold-out)"),
    Option("dem", "raster", None, "DEM (footprints and orthorectification; empty = mean height of the points)",
           "DEM for the footprints and --orthorectify [the mean height of the adjusted points]."),
    Option("orthorectify", "bool", False, "Orthorectify every frame with its adjusted orientation",
           "Write <frame>_ortho.tif: every frame orthorectified with its adjusted orientation and the DEM."),
    Option("mosaic", "bool", False, "Mosaic the orthorectified frames (mosaic.tif, seamlines in mosaic.gpkg)",
           "Write mosaic.tif: the frames orthorectified (implies --orthorectify) and mosaicked as fotogeo mosaic "
           "does (seamlines, balancing, feathering), its seamlines in mosaic.gpkg; one pixel size for all [the "
           "median GSD of the frames]. A failing mosaic is reported and leaves the other outputs."),
    Option("resolution", "float", None, "Orthophoto pixel size (0 = each frame's ground sample distance)",
           "Pixel size of the orthorectified frames [each frame's GSD; with --mosaic their median].", minimum=0.0,
           exclusive_minimum=True, automatic=0.0, advanced=True),
    replace(RESAMPLING, label="Orthorectification resampling", advanced=True),
    replace(UNCERTAINTY, label="Uncertainty rasters beside the orthophotos (<frame>_ortho_sigma.tif)",
            help="Also write <frame>_ortho_sigma.tif beside each orthophoto (with --orthorectify or --mosaic): the "
                 "predicted planimetric sigma (m) of every cell, from this adjustment's covariance and the DEM's "
                 "sigma (--dem-sigma), as fotogeo ortho --uncertainty writes it."),
    replace(DEM_SIGMA, help="Height sigma of the DEM (m) for --uncertainty [half the DEM's cell; required without "
                            "--dem]."),
    Option("reference_sigma_xy", "float", None, "σ of automatic control X, Y (m; empty = half the orthophoto's "
           "pixel)", "σ of the X, Y of control found on the reference orthophoto (--reference), m [half its "
           "pixel].", minimum=0.0, exclusive_minimum=True, advanced=True),
    Option("reference_sigma_z", "float", None, "σ of automatic control heights (m; empty = half the DEM's pixel)",
           "σ of the heights of control found on the reference (from the DEM), m [half the DEM's pixel, at "
           "least the X, Y σ].", minimum=0.0, exclusive_minimum=True, advanced=True),
    Option("eo_sigma_height", "float", None, "σ of the approximate projection-centre heights (m; empty = as X, Y)",
           "σ of the approximate projection-centre heights, e.g. GNSS vertical (m) [--eo-sigma-position, or the "
           "images' own GNSS accuracy tags].", minimum=0.0, exclusive_minimum=True, advanced=True),
    Option("geoinfo", "file", None, "senseFly geoinfo.txt (GPS and autopilot attitude per image)",
           "senseFly geotag file (fileName latitude longitude altitude heading pitch roll) giving the approximate "
           "orientation of images without --eo.", file_filter="Text files (*.txt);;All files (*)"),
    Option("undetermined", "choice", "fail", "A frame the block does not determine: fail the run, or drop it",
           "What to do with a frame the adjustment does not determine (too few or clustered points, angle σ "
           "above --max-angle-sigma): fail (default) or drop it, re-adjust and report it.",
           choices=UNDETERMINED),
    Option("max_angle_sigma", "float", 0.5, "Largest angle σ of a determined frame (°)",
           "A frame whose adjusted ω, φ, κ have a σ above this (degrees) is undetermined.", minimum=0.0,
           exclusive_minimum=True, advanced=True),
    Option("min_frame_points", "int", 6, "Fewest points that determine a frame",
           "A frame observing fewer distinct points than this is undetermined.", minimum=3, advanced=True),
    Option("detection_level", "int", None, "Pyramid level of tie-point detection (empty = from the frame size)",
           "Pyramid level on which tie points are detected (0 = full resolution) [1, or the level that brings a "
           "frame to ≤ 4 Mpx].", minimum=0, maximum=6, advanced=True),
    Option("gruber_cells", "int", 3, "Regions per frame side for tie-point thinning (3 = Gruber's 9 positions)",
           "Each frame is cut into N x N regions for tie-point thinning (3: Gruber's nine positions).", minimum=1,
           maximum=12, advanced=True),
    Option("points_per_region", "int", 25, "Tie points kept per region (0 = all)",
           "Tracks kept per region of a frame, most rays first (0: keep every track).", minimum=0, automatic=0,
           advanced=True),
    Option("lsm_window", "int", 21, "Least-squares matching window (px, odd)",
           "Side of the least-squares matching window of the tie points (px).", minimum=7, maximum=101,
           advanced=True),
    replace(SCHEDULER, label="Dask scheduler address for the pair matching (empty = local)",
            help="Match the frame pairs as tasks on this Dask scheduler, e.g. tcp://host:8786 [this process].",
            advanced=True),
    replace(WORKERS, label="Local Dask workers for the pair matching (0 = none: this process)",
            help="Match the frame pairs as tasks on a local Dask cluster of N processes [0: in this process].",
            advanced=True),
)
#: batch co-registration (``register_batch``): where the scenes run and resuming; each scene takes
#: the options of :data:`REGISTER` and :data:`REGISTER_TERRAIN` (a DEM: terrain-aware)
REGISTER_BATCH = Table(
    SCHEDULER, WORKERS,
    Option("resume", "bool", True, "Skip scenes already registered (manifest and outputs)",
           "Skip scenes whose outputs and manifest row say they are done."),
)


_PYTHON_TYPES = {"int": "int", "float": "float", "bool": "bool", "str": "str", "choice": "str", "crs": "str"}


def _validate(self) -> None:
    """Check every field against :data:`REGISTER` (kind, range, choices); :class:`InputError` names it."""
    for f in fields(self):
        REGISTER[f.name].check(getattr(self, f.name))


RegisterOptions = make_dataclass(
    "RegisterOptions", [(o.name, f"{_PYTHON_TYPES[o.kind]} | None" if o.nullable else _PYTHON_TYPES[o.kind],
                         field(default=o.default))
                        for o in REGISTER.values()],
    frozen=True, namespace={"validate": _validate,
                            "__doc__": "Parameters of :func:`fotogeo.tools.register.register` (declared in "
                                       ":data:`fotogeo.options.REGISTER`; CLI flags of the same names)."})
RegisterOptions.__module__ = __name__


def find_option(name: str) -> Option | None:
    """The first option declared as ``name`` in this module's tables (for a message's flag or label), or None.

    >>> find_option("half_window").cli_flag, find_option("nope")
    ('--half-window', None)
    """
    from .options_coreg import COREG  # declared apart (this module's size); they import this one
    from .options_interior import INTERIOR
    from .options_products import MOSAIC, ORTHO
    for table in [v for v in globals().values() if isinstance(v, Table)] + [COREG, ORTHO, MOSAIC, INTERIOR]:
        if name in table:
            return table[name]
    return None
