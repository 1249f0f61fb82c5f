"""``fotogeo dsm``: a digital surface model (and a point cloud) from oriented images.

``dsm(images, output, camera=..., eo=... | orientation=... | rpc=True, ...)`` — what it offers, step by step:

1. **orientation**: frame cameras from ``--camera``/``--eo`` (the formats ``fotogeo ortho`` reads,
   :mod:`fotogeo.tools.ortho.inputs`) or triangulate's output folder (``--orientation``); or ``--rpc``: each
   image's RPC (GDAL metadata, or a .geom/.RPB/_RPC.TXT/XML beside it), matched in locally epipolar tiles after a
   relative pointing correction (:mod:`.rpc_pairs`, :mod:`.rpc_tool`);
2. **pairs** (:mod:`.plan`, :mod:`fotogeo.stereo.pairs`): chosen from the footprints, the overlap, the
   base-to-height ratio and the angle between the views, or given (``--pairs``); the report says why each pair
   was kept or left out;
3. **per pair** (:mod:`.frames`): exact epipolar rectification with the lens distortion removed
   (:mod:`fotogeo.stereo.rectify`), a sparse check of the orientation (epipolar residuals, rays' miss distances),
   the disparity range from the heights (``--dem`` fitted to the sparse matches, :mod:`.dem_guide`, else
   sparse matches), semi-global matching with sub-pixel
   disparities and left–right, uniqueness and speckle filters (:mod:`fotogeo.stereo.dense`) strip by strip, and
   triangulation of every matched pixel (:mod:`fotogeo.stereo.rays`) — by output tiles (:mod:`.matching`): each
   tile's pixels matched from the windows of the images they need, so memory is bounded by the tile;
4. **fusion** (:mod:`fotogeo.stereo.fusion`): the pairs' points on one north-up grid (``--resolution``,
   ``--crs``, ``--bounds``), the median of the pairs, a count and a spread band; holes stay nodata unless
   ``--fill`` (then marked in a fourth band); output tile by output tile for frames and RPC pairs alike
   (:mod:`.matching`), so memory is bounded by the tile, not the images or the grid; the tiles run in this
   process or, with ``--workers``/``--scheduler``, as Dask tasks on the cluster of ``triangulate`` and ``mosaic``
   (each task reads its own windows; this process writes the returned tiles);
5. **outputs** (:mod:`.outputs`), all or nothing: the DSM (COG layout), ``--point-cloud`` (LAS 1.4 with the CRS
   as WKT and the left image's colours, :mod:`fotogeo.io.las`) and ``--report`` (JSON: pairs kept and left out
   and why, disparity ranges, match density, epipolar residuals and ray miss distances, completeness, timings);
   a run refused after the outputs' checks writes the report alone, ``"status": "refused"`` with the error and the
   pairs tried (:mod:`.refusal`).

Heights are in the vertical frame of the orientation (the DEM's when one is given and the orientation states
none); RPC heights are ellipsoidal.
"""
from .tool import dsm

__all__ = ["dsm"]
