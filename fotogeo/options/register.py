"""The registration's options (``fotogeo register``, ``match``, ``fuse``, ``demo``, ``register-batch``) and
:class:`RegisterOptions`, the registration settings as a frozen dataclass checked against :data:`REGISTER`."""
from __future__ import annotations

from dataclasses import field, fields, make_dataclass, replace

from .shared import (CONTRASTS, DETECTOR, EXAGGERATION, MAX_KEYPOINTS, PLANAR_MODELS, RANSAC_THRESHOLD, RATIO, REFINES, RESAMPLING, SCHEDULER, SEED, TERRAIN_MODELS, WORKERS, YAML)
from .table import Option, Table

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
    Option("dst_crs", "crs", "auto", "Output CRS (empty = the reference's, or UTM if it is geographic)",
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
    Option("refine", "choice", "auto", "Refine tie points before the fit (auto = lsm)",
           "Refine tie points by least-squares matching before the fit: auto = lsm, with or without --dem.", choices=REFINES, advanced=True),
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
           "When feature matching finds too few matches or inliers (or keeps fewer than 12), match a grid of windows "
           "(area-based, robust to seasonal change) for the tie points instead, on the target's georeference or, "
           "for an unreferenced target, on a Fourier-Mellin pre-alignment (any rotation, scale 0.4-2.5; refused "
           "when not credible); the report says so.", advanced=True),
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
                            "__doc__": "Parameters of :func:`fotogeo.tools.register.tool.register` (declared in "
                                       ":data:`fotogeo.options.REGISTER`; CLI flags of the same names)."})
RegisterOptions.__module__ = __name__
