"""The choice lists and the options several tools share, declared once (the tools' tables in the sibling
modules take them from here)."""
from __future__ import annotations

from .table import Option

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
#: tie-point refinement: ``auto`` = ``lsm`` (fotogeo.tools.register.points.refine_mode)
REFINES = ("none", "lsm", "auto")
POLARITIES = ("auto", "bright", "dark")
SPREADS = ("homogeneous", "heterogeneous")
#: interior parameters a bundle adjustment may estimate (self-calibration; fotogeo.orientation.bundle_jacobian)
INTERIOR_PARAMETERS = ("f", "ppx", "ppy", "k1", "k2", "k3", "p1", "p2")
#: Ebner's (1976) 12 additional parameters (fotogeo.orientation.bundle_jacobian); "ebner" names all of them
EBNER_PARAMETERS = tuple(f"b{i}" for i in range(1, 13))
SELF_CALIBRATION = INTERIOR_PARAMETERS + EBNER_PARAMETERS + ("ebner", "none")
#: what an empty --self-calibration estimates for a camera guessed from the images' EXIF (no calibration in
#: their files), as ODM and Metashape refine a camera by default; parameters the block cannot tell from the
#: orientation are then held fixed (fotogeo.orientation.bundle's correlation rule)
AUTO_SELF_CALIBRATION = ("f", "ppx", "ppy", "k1", "k2", "p1", "p2")
#: what triangulate does with a frame the block does not determine
UNDETERMINED = ("drop", "fail")
#: height references a DEM may be given in (fotogeo.geometry.vertical); auto = what its CRS states
DEM_HEIGHTS = ("auto", "ellipsoid", "geoid")
#: image representations of the area-based co-registration (fotogeo.coreg.representation)
COREG_REPRESENTATIONS = ("orientation", "gradient", "rank", "intensity")
#: compression of the GeoTIFF outputs (fotogeo.io.compression); deflate first: the default every TIFF reader reads
COMPRESSIONS = ("deflate", "zstd", "lzw", "none")

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
#: the GeoTIFF outputs' compression (``fotogeo ortho`` and ``fotogeo mosaic``; fotogeo.io.compression)
COMPRESS = Option("compress", "choice", "deflate", "Compression (zstd: faster, read by GDAL >= 2.3 and QGIS)",
                  "Compression of the GeoTIFF outputs: deflate (every TIFF reader), zstd (level 1: faster to write; "
                  "GDAL >= 2.3 and QGIS read it, some older TIFF readers do not), lzw or none.",
                  choices=COMPRESSIONS, advanced=True)
#: the planimetric σ raster beside each orthophoto (``fotogeo ortho`` and ``triangulate --orthorectify``) and the
#: DEM's height σ it adds (fotogeo.tools.ortho.products)
UNCERTAINTY = Option("uncertainty", "bool", False,
                     "Uncertainty raster: planimetric σ per cell (<orthophoto>_sigma.tif)",
                     "Also write <orthophoto>_sigma.tif: the predicted planimetric sigma (m) of every cell, from the "
                     "covariance in triangulate's report.json beside --eo and the DEM's sigma (--dem-sigma).")
DEM_SIGMA = Option("dem_sigma", "float", None, "Height σ of the DEM for the uncertainty, m (0 = half the DEM's cell)",
                   "Height sigma of the DEM (m) for --uncertainty [half the DEM's cell].", minimum=0.0,
                   exclusive_minimum=True, automatic=0.0, advanced=True)
YAML = "YAML (*.yaml *.yml)"
#: the local frame of an OpenSfM/ODM reconstruction.json given as --eo (fotogeo.io.sfm_frame)
SFM_FRAME = Option("sfm_frame", "choice", "auto", "OpenSfM/ODM local frame (auto = from the images' GPS)", "Local frame of an OpenSfM/ODM reconstruction.json (--eo): topocentric (OpenSfM) or "
                   "grid (ODM's offsets along the UTM grid) [auto: decided by the images' own GPS or exif/; refused "
                   "when nothing decides].", choices=("auto", "topocentric", "grid"), advanced=True)
#: the QGIS style written beside a DSM (``fotogeo dsm``, ``triangulate --dsm``; fotogeo.io.qml)
QGIS_STYLE = Option("qgis_style", "bool", True, "Write a QGIS style (.qml) beside the DSM",
                    "Write <name>.qml beside the DSM: QGIS opens band 1, the height, in colour over its 2-98 % range "
                    "(a .qml fotogeo did not write is replaced only with --overwrite).")
#: where Dask tasks run: register-batch's scenes, triangulate's pairs (fotogeo.tools.register.batch._cluster)
SCHEDULER = Option("scheduler", "str", None, "Dask scheduler address (empty = a local cluster)",
                   "Address of a running Dask scheduler, e.g. tcp://host:8786 [a local cluster on this machine].")
WORKERS = Option("workers", "int", None, "Local Dask workers (0 = one per CPU)", "Workers of the local cluster [one "
                 "per CPU].", minimum=0, automatic=0)
