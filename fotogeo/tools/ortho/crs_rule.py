"""The map CRS of ``fotogeo ortho`` and ``fotogeo dsm`` (one rule for both): a fitted model's, the CRS of its GCPs
(another ``--crs`` is refused); ``--crs``; else the DEM's horizontal CRS when projected; else the CRS of the
orientation file (SfM, orthority, or the ``# fotogeo …, CRS …`` header triangulate writes); else the UTM zone of the
image centre (RPC). Frame orientations from a ``.txt`` file without that header are in the map CRS; an orientation
file in another CRS than the one given is refused (mixed CRSs).

A geographic ``--crs`` is refused (the outputs are measured in metres), the hint naming only a choice that works for
the inputs given (:func:`_automatic_choice`): ``'auto'`` with what it would take when the rule above finds a CRS
without ``--crs``, else the CRS of the orientation's X, Y.
"""
from __future__ import annotations

from ...crs import parse_crs, require_projected, utm_crs_for
from ...errors import InputError
from ...geometry.vertical import horizontal_crs, is_projected
from ...io.block import frame_key
from ...io.camera import exterior_orientation_crs
from ...io.orientation_file import is_block_file
from ...io.raster import open_raster
from .inputs import _no_orientation, orientation_block, read_fitted_model


def map_crs(dst_crs, dem, eo, images, rpc, camera=None, model=None, sfm_frame="auto", rpc_of=None,
            crs_option="dst_crs") -> tuple:
    """``(projected CRS, rule)`` of the module docstring (``rpc_of`` as :func:`.inputs.image_models`';
    ``crs_option``: the tool's name of the option ``dst_crs`` comes from, which a refusal of it names)."""
    if model is not None:
        c = require_projected(horizontal_crs(parse_crs(read_fitted_model(model)[1], "--model")), "CRS of --model",
                              choice=None)
        given = None if not dst_crs or str(dst_crs).strip().lower() == "auto" else parse_crs(dst_crs, "--crs")
        if given is not None and not horizontal_crs(given).equals(c):
            raise InputError(f"--crs differs from the CRS of the fitted model's GCPs ({c.name}): the model takes "
                             f"map coordinates in that CRS; leave --crs out", option="dst_crs")
        return c, "the CRS of the fitted model's GCPs (--model)"
    if dst_crs and str(dst_crs).strip().lower() != "auto":
        try:
            c = horizontal_crs(parse_crs(dst_crs, "--crs"))
            if not (c.is_geographic or c.is_geocentric):
                return c, "given (--crs)"
            choice = _automatic_choice(dem, eo, images, rpc, camera, sfm_frame, rpc_of)
            return require_projected(c, "output CRS (--crs)", choice=choice), "given (--crs)"
        except InputError as e:  # the option's name for the report of the refusal and QGIS's label
            raise InputError(str(e), option=crs_option, also=e.also) from None
    if dem is not None:
        info = open_raster(dem, "DEM")
        if info.raster_crs is None:
            raise InputError(f"DEM {str(dem)!r} has no CRS; assign one (gdal_edit.py -a_srs) so that it can be "
                             f"placed under the images")
        h = horizontal_crs(info.raster_crs)  # rasterio's: no pyproj when the run needs none (fotogeo.crs)
        if is_projected(h):
            return h, "the DEM's CRS (--dem)"
    if eo is not None and not rpc:
        stated = (getattr(orientation_block(eo, None, camera, sfm_frame, images), "crs", None) if is_block_file(eo)
                  else exterior_orientation_crs(eo))  # fotogeo's lines state it in their header, if at all
        if stated is not None:
            return (require_projected(horizontal_crs(stated), f"CRS of --eo {str(eo)!r}", choice=None),
                    f"the CRS of --eo {str(eo)!r}")
        raise InputError("no map CRS for the exterior orientation: give --crs (the CRS of its X, Y) or a DEM in a "
                         "projected CRS")
    if rpc and images:
        from ...io.rpc_image import image_rpc
        r = (rpc_of or image_rpc)(images[0]).rpc
        return utm_crs_for(r.long_off, r.lat_off), "the UTM zone of the image centre (RPC)"
    if eo is None and not rpc and images:  # what is missing is the orientation, not the CRS
        _no_orientation([frame_key(p) for p in images])
    raise InputError("no map CRS: give --crs (a projected CRS) or a DEM in a projected CRS")


def _automatic_choice(dem, eo, images, rpc, camera, sfm_frame, rpc_of) -> str | None:
    """The words for the choice that works for these inputs when the ``--crs`` given is geographic: ``'auto'``
    and the CRS it takes when the rule finds one (the DEM's, the orientation file's, the RPC's UTM zone); else,
    for frames, the CRS of the orientation's X, Y (which ``--crs`` states for a ``.txt`` without a header); else
    None. ``'auto'`` alone sent the user of frames without a DEM to a run refused for want of a map CRS."""
    try:
        rule = map_crs(None, dem, eo, images, rpc, camera, sfm_frame=sfm_frame, rpc_of=rpc_of)[1]
    except InputError:
        return "the CRS the X, Y of --eo are in" if eo is not None and not rpc else None
    return f"'auto': {rule}"
