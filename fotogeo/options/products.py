"""The product tools' options (``fotogeo ortho``, ``fotogeo mosaic``, QGIS ``fotogeo:ortho`` and
``fotogeo:mosaic``), declared as every tool's are in :mod:`fotogeo.options` (standard library only, like it)."""
from __future__ import annotations

from .register import REGISTER_BATCH
from .shared import COMPRESS, DEM_HEIGHTS, DEM_SIGMA, RESAMPLING, SFM_FRAME, UNCERTAINTY, YAML
from .table import Option, Table

#: orthorectification of oriented images (``fotogeo ortho``, fotogeo.tools.ortho.tool)
ORTHO = Table(
    Option("dem", "raster", None, "DEM or DSM (heights of the output cells)",
           "DEM, or DSM for occlusion masking: the height of every output cell (bilinear)."),
    Option("camera", "file", None, "Camera (interior orientation YAML; empty = from the orientation file)",
           "Interior orientation YAML (pinhole, or brown: triangulate's camera.yaml) [the --eo file's cameras].",
           file_filter=YAML),
    Option("eo", "path", None, "Exterior orientation (text, OpenSfM, COLMAP or orthority)",
           "Exterior orientation: 'name X Y Z omega phi kappa' lines (map CRS, degrees; triangulate's "
           "exterior_orientation.txt), OpenSfM/ODM reconstruction.json, a COLMAP model (its folder, images.txt or "
           "images.bin), "
           "orthority .geojson/.csv.",
           file_filter="Orientation (*.txt *.json *.geojson *.csv *.bin);;All files (*)"),
    SFM_FRAME,
    Option("rpc", "bool", False, "Images carry an RPC (GDAL RPC metadata: vendor, or rpc-bias's copy)",
           "The images carry an RPC in their GDAL RPC metadata (vendor, or rpc-bias's corrected copy)."),
    Option("model", "file", None, "Fitted orient model (orient's JSON report; one image)",
           "orient's JSON report (--report R.json): orthorectify the one image through its fitted ground -> image "
           "model, in the CRS of its GCPs.", file_filter="JSON (*.json);;All files (*)"),
    Option("height", "float", None, "Constant height instead of a DEM",
           "A constant height for every cell, knowingly, instead of a DEM."),
    Option("dem_heights", "choice", "auto", "Height reference of the DEM (auto = what its CRS states)",
           "Height reference of the DEM: auto (what its CRS states), ellipsoid or geoid.", choices=DEM_HEIGHTS,
           advanced=True),
    Option("geoid", "raster", None, "Geoid undulations N (h = H + N) for a geoid DEM under an RPC",
           "Raster of geoid undulations N (e.g. egm96_15.gtx) making geoid DEM heights ellipsoidal (h = H + N).",
           advanced=True),
    Option("occlusion", "bool", False, "Occlusion masking (hidden ground becomes nodata)",
           "Trace every cell's line of sight through the DEM/DSM: hidden ground becomes nodata."),
    Option("resolution", "float", None, "Pixel size (0 = each image's ground sample distance)",
           "Output pixel size in map units [each image's GSD].", minimum=0.0, exclusive_minimum=True,
           automatic=0.0),
    Option("dst_crs", "crs", "auto", "Output CRS (empty = the DEM's when projected)",
           "Output CRS: auto = the DEM's when projected, else the orientation file's, else the UTM zone (RPC); "
           "or EPSG:xxxx, WKT, PROJ. Orientations from .txt lines are in it.", flag="--crs", param="CRS"),
    RESAMPLING,
    Option("error_threshold", "float", 0.125, "Error threshold of the interpolated cell positions (px; 0 = exact)",
           "Largest distance (image pixels) of a frame's cell positions interpolated on a checked lattice from the "
           "exact ones, like gdalwarp -et; 0 computes every cell exactly.", minimum=0.0, advanced=True),
    Option("cog", "bool", False, "Write Cloud Optimized GeoTIFFs (COG)",
           "Write Cloud Optimized GeoTIFFs (GDAL's COG layout).", advanced=True),
    COMPRESS,
    UNCERTAINTY,
    DEM_SIGMA,
    Option("view_bands", "bool", False,
           "View geometry raster: off-nadir angle and distance (*_view.tif)",
           "Also write <orthophoto>_view.tif: band 1 the off-nadir angle of the line of sight (degrees), band 2 the "
           "distance from the ground to the projection centre (m; frames only)."),
)
#: orthophoto mosaics (``fotogeo mosaic``, fotogeo.tools.ortho.mosaic)
MOSAIC = Table(
    Option("feather", "float", None, "Feather width across seams (map units; 0 = automatic)",
           "Width of the blending ramp across each seamline, in map units [16 pixels or two seam cells].",
           minimum=0.0, exclusive_minimum=True, automatic=0.0),
    Option("balance", "bool", True, "Balance radiometry (gain and offset per image from the overlaps)",
           "A gain and an offset per image and band from the overlaps' means and spreads."),
    Option("dsm", "raster", None, "DSM: seamlines avoid above-ground objects (buildings, trees)",
           "DSM: seamlines go around cells more than 2.5 m above the local ground (the DSM's morphological "
           "opening over 40 m)."),
    COMPRESS,
) + REGISTER_BATCH.only("scheduler", "workers", scheduler={
    "help": "Blend the tiles on the running Dask scheduler at this address, e.g. tcp://host:8786 (the workers "
            "must see the same paths) [threads in this process].", "advanced": True}, workers={
    "label": "Local Dask workers (0 = threads in this process)", "advanced": True,
    "help": "Blend the tiles on a local Dask cluster of this many worker processes [threads in this process]."})
