"""The aerial triangulation's options (``fotogeo triangulate``)."""
from __future__ import annotations

from dataclasses import replace

from .shared import (COMPRESS, DEM_SIGMA, QGIS_STYLE, RESAMPLING, SCHEDULER, SEED, SELF_CALIBRATION, SFM_FRAME,
                     UNCERTAINTY, UNDETERMINED, WORKERS)
from .table import Option, Table

#: aerial triangulation (``fotogeo triangulate``, fotogeo.tools.triangulate)
TRIANGULATE = Table(
    Option("crs", "crs", None, "Map CRS of the block (empty = from the GCPs, orthophotos, DEM or GPS)", "Projected map CRS of the block [the GCPs' CRS, else the reference orthophoto's, the "
           "DEM's, or the UTM zone of the images' GPS]."),
    Option("gcp_crs", "crs", None, "CRS of the GCP file's ground X, Y (empty = its own, else the map CRS)",
           "CRS of the GCPs' ground x, y when the file carries none (CSV) or to override it [the map CRS]."),
    Option("check_points", "str", None, "GCP names used as check points (comma-separated)",
           "Comma-separated GCP names held out as check points."),
    Option("self_calibration", "choices", None, "Interior parameters to estimate (empty = auto; none = fixed)",
           "Comma-separated interior parameters to estimate (ebner: Ebner's 12 additional parameters "
           "b1-b12; none: the camera held fixed) [a camera read from the images' EXIF without a calibration in "
           "their files: f,ppx,ppy,k1,k2,p1,p2 with 3 frames or more; a --camera file, an SfM file's camera or a "
           "calibration the images carry (DJI DewarpData): fixed].", choices=SELF_CALIBRATION),
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
    Option("check_fraction", "float", None, "Fraction of the control held out as check points (empty = auto)",
           "Fraction of the control points held out as check points, spread over the block (seeded) [0.2 when "
           "no check points are named and >= 10 control points are measured in two frames or more, else 0].",
           minimum=0.0, maximum=0.9),
    replace(SEED, label="Random seed (check-point hold-out)"),
    Option("dem", "raster", None, "DEM (footprints, orthophotos; empty = mean height of the points)",
           "DEM for the footprints and --orthorectify [the mean height of the adjusted points]."),
    Option("orthorectify", "bool", False, "Orthorectify every frame with its adjusted orientation",
           "Write <frame>_ortho.tif: every frame orthorectified with its adjusted orientation and the DEM."),
    Option("mosaic", "bool", False, "Mosaic the orthorectified frames (mosaic.tif)",
           "Write mosaic.tif: the frames orthorectified (implies --orthorectify) and mosaicked as fotogeo mosaic "
           "does (seamlines, balancing, feathering), its seamlines in mosaic.gpkg; one pixel size for all [the "
           "median GSD of the frames]. A failing mosaic is reported and leaves the other outputs."),
    Option("dsm", "raster_out", None, "Surface model (DSM) of the adjusted frames",
           "Also write a DSM (GeoTIFF) here: the adjusted frames matched and fused as fotogeo dsm does "
           "(its default pairs and resolution; --dem bounds the heights searched). A failing DSM is reported and "
           "leaves the other outputs."),
    replace(QGIS_STYLE, help="Write <name>.qml beside the --dsm: QGIS opens band 1, the height, in colour over its "
                             "2-98 % range (a .qml fotogeo did not write is replaced only with --overwrite)."),
    Option("resolution", "float", None, "Orthophoto pixel size (0 = each frame's ground sample distance)",
           "Pixel size of the orthorectified frames [each frame's GSD; with --mosaic their median].", minimum=0.0,
           exclusive_minimum=True, automatic=0.0, advanced=True),
    replace(RESAMPLING, label="Orthorectification resampling", advanced=True),
    replace(COMPRESS, label="Orthophoto and mosaic compression (zstd: faster; GDAL >= 2.3, QGIS)",
            help="Compression of the orthophotos, their sigma rasters and the mosaic (--orthorectify, --mosaic): "
                 "deflate (every TIFF reader), zstd (level 1: faster to write; GDAL >= 2.3 and QGIS read it, some "
                 "older TIFF readers do not), lzw or none."),
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
    SFM_FRAME,
    Option("geoinfo", "file", None, "senseFly geoinfo.txt (GPS and autopilot attitude per image)",
           "senseFly geotag file (fileName latitude longitude altitude heading pitch roll) giving the approximate "
           "orientation of images without --eo.", file_filter="Text files (*.txt);;All files (*)"),
    Option("undetermined", "choice", "drop", "Undetermined frames",
           "What to do with a frame the adjustment does not determine (too few or clustered points, angle σ "
           "above --max-angle-sigma): drop it, re-adjust and report it (default; refused when fewer than 2 "
           "frames or less than half of them would remain), or fail the run.",
           choices=UNDETERMINED),
    Option("max_angle_sigma", "float", 0.5, "Largest angle σ of a determined frame (°)",
           "A frame whose adjusted ω, φ, κ have a σ above this (degrees) is undetermined.", minimum=0.0,
           exclusive_minimum=True, advanced=True),
    Option("min_frame_points", "int", 6, "Fewest points that determine a frame",
           "A frame observing fewer distinct points than this is undetermined.", minimum=3, advanced=True),
    Option("detection_level", "int", None, "Pyramid level of tie-point detection (empty = from the frame size)",
           "Pyramid level on which tie points are detected (0 = full resolution) [1, or the level that brings a "
           "frame to ≤ 4 Mpx].", minimum=0, maximum=6, advanced=True),
    Option("gruber_cells", "int", 3, "Tie-point thinning: regions per frame side (3 = Gruber's 9)",
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
