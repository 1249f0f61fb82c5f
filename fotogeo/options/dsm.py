"""The surface-model tool's options (``fotogeo dsm``, QGIS ``fotogeo:dsm``), declared as every tool's are in
:mod:`fotogeo.options` (standard library only, like it)."""
from __future__ import annotations

from dataclasses import replace

from .products import ORTHO
from .shared import DEM_HEIGHTS, QGIS_STYLE, SCHEDULER, WORKERS
from .table import Option, Table

#: dense matching of oriented images to a surface model (``fotogeo dsm``, fotogeo.tools.dsm)
DSM = Table(
    *ORTHO.only("camera", "eo", "sfm_frame").values(),  # the orientation files ortho reads, declared once
    Option("orientation", "folder", None, "triangulate's output folder (its camera and orientation)",
           "triangulate's output folder: its exterior_orientation.txt and camera.yaml instead of --eo "
           "(and of --camera unless given)."),
    Option("rpc", "bool", False, "Images carry an RPC (GDAL RPC metadata, RPB/XML/.geom beside them)",
           "The images carry an RPC (GeoTIFF RPC tags, RPC/RPB/XML files or an OSSIM .geom beside them)."),
    Option("dem", "raster", None, "Reference DEM (disparity search range; empty = from sparse matches)",
           "A coarse DEM/DSM (e.g. SRTM) bounding the heights searched; frames: each strip searches around "
           "it, fitted to each pair's sparse matches (an offset is named and removed) [from sparse matches]."),
    Option("dem_heights", "choice", "auto", "Height reference of the DEM (auto = what its CRS states)",
           "Height reference of the DEM: auto (what its CRS states), ellipsoid or geoid.", choices=DEM_HEIGHTS,
           advanced=True),
    replace(ORTHO["geoid"], label="Geoid undulations N (h = H + N) making a geoid DEM ellipsoidal"),
    Option("pairs", "file", None, "Pairs to match (text file; empty = chosen automatically)",
           "A text file of the pairs to match, two image names (file names without extension) per line [chosen "
           "from footprints, overlap, base-to-height ratio and view angle; a given pair is matched even when its views "
           "differ by more than 45 degrees].", file_filter="Text (*.txt);;All files (*)"),
    Option("resolution", "float", None, "Cell size (0 = twice the images' ground sample distance)",
           "Cell size of the DSM in map units [twice the median ground sample distance of the pairs].",
           minimum=0.0, exclusive_minimum=True, automatic=0.0),
    Option("crs", "crs", "auto", "Output CRS (empty = the DEM's when projected, else the orientation's)",
           "Output CRS: auto = the DEM's when projected, else the orientation file's, else the UTM zone (RPC); "
           "or EPSG:xxxx, WKT, PROJ. Orientations from .txt lines are in it.", param="CRS"),
    Option("bounds", "str", None, "Extent (xmin,ymin,xmax,ymax; empty = the pairs' overlap)",
           "Extent of the DSM 'xmin,ymin,xmax,ymax' in the output CRS [the union of the pairs' overlaps]."),
    Option("refine", "bool", False, "Least-squares refinement of the disparities (slower)",
           "Refine the sub-pixel disparities by least-squares matching over 11 x 11 windows (shift along the "
           "epipolar line, radiometric offset and gain; Gruen 1985). Slower.",
           advanced=True),
    Option("fill", "bool", False, "Fill holes (interpolated cells are marked in a mask band)",
           "Fill the holes by interpolation (Telea); a fourth band marks the filled cells (1). Default: holes "
           "stay nodata."),
    Option("fill_max_distance", "float", 4.0, "Fill at most this many cells from a matched height",
           "With --fill: fill only the cells at most this many cells (the Euclidean distance between cell "
           "centres, as gdal_fillnodata -md counts pixels) from a matched height; farther cells stay nodata and "
           "are not marked filled. At most 64 (the output tiles' margin).", minimum=0.0, maximum=64.0,
           exclusive_minimum=True, advanced=True, needs="fill"),
    Option("bands", "str", None, "Bands to match, e.g. 1 or 4,3,2 (empty = the first three)",
           "Bands of each image fused into the grey image matched, e.g. 1 or 4,3,2 [the first three; empty, "
           "constant and noise bands left out with a warning]; the point cloud's colours come from them too.",
           advanced=True),
    QGIS_STYLE,
    replace(SCHEDULER, label="Dask scheduler address for the output tiles (empty = this process)",
            help="Match the output tiles as tasks on this Dask scheduler, e.g. tcp://host:8786 (the workers must "
                 "see the same paths) [this process].", advanced=True),
    replace(WORKERS, label="Local Dask workers for the output tiles (0 = none: this process)",
            help="Match the output tiles as tasks on a local Dask cluster of N processes [0: in this process].",
            advanced=True),
)
