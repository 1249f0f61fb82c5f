"""``fotogeo triangulate … --dsm DSM.tif``: the surface model of the block, made from the adjusted frames by the
pipeline of ``fotogeo dsm`` (:func:`fotogeo.tools.dsm.dsm`: pairs, rectification, matching and fusion by tiles)
with the orientation this run wrote (``exterior_orientation.txt`` and ``camera.yaml``), in the block's map
CRS, its heights searched within the ``--dem`` when one was given. It runs after the adjustment's outputs are
written: a DSM that cannot be made is reported (``report.json`` ``dsm.error``, a warning naming the fix) and
leaves them in place, as a failing mosaic does.
"""
from __future__ import annotations

import warnings
from pathlib import Path


def block_dsm(path, paths: dict, crs, dem, overwrite: bool, frames, progress, rule=None,
              qgis_style: bool = True) -> dict:
    """The DSM of the adjusted ``frames`` written to ``path`` (module docstring); ``paths`` the run's outputs
    (:func:`~fotogeo.tools.triangulate.outputs.output_paths`), ``crs`` the block's map CRS, ``rule`` how the block
    chose it (``start.crs_rule``): the DSM's ``crs_rule``; ``qgis_style`` as dsm's. Returns the DSM's report, or
    ``{"error": ...}``."""
    from ...errors import Cancelled, FotogeoError, FotogeoWarning
    from ..dsm import dsm
    folder = Path(paths["eo"]).parent
    try:
        rep = dsm([str(f) for f in frames], path, camera=paths["camera"], eo=paths["eo"], crs=crs.to_wkt(),
                  dem=dem, qgis_style=qgis_style, overwrite=overwrite, progress=progress)
        rep["crs_rule"] = f"the block's map CRS{f': {rule}' if rule else ''}"
        return rep
    except Cancelled:
        raise
    except FotogeoError as exc:
        message = (f"no DSM: {exc}; the orientations are written (make the DSM with fotogeo dsm FRAMES "
                   f"--orientation {folder})")
        warnings.warn(message, FotogeoWarning, stacklevel=2)
        return {"error": message}
