"""Aerial triangulation of a block of frames (``fotogeo triangulate``), one capability in several modules.

* :mod:`.tool` — :func:`triangulate`, the tool (paths in, folder out; its docstring lists inputs and outputs),
  and :mod:`.determinacy`, :func:`adjust_determined` (the adjustment with every frame's determinacy checked, a
  frame whose attitude prior its ties contradict re-started from the block);
* :mod:`.sources` — camera, approximate orientation, map CRS and GNSS σ from any source;
* :mod:`.inputs` — camera with distortion, control in any CRS, check split, space resection;
* :mod:`.start` — κ and terrain height measured on the matched pairs;
* :mod:`.match` — tie points: footprints, pair matching with epipolar RANSAC, multi-ray tracks,
  Gruber thinning, LSM transfer with σ;
* :mod:`.control` — automatic control from reference orthophotos + DEM, with every frame's fitted pose;
* :mod:`.register` — the start of a block without EO or GCPs from those poses;
* :mod:`.ortho` — adjusted frames as ground→image models, footprints, orthorectification;
* :mod:`.outputs` — the output set; :mod:`.report` — ``report.html`` with plots.

Imports inside the package go from :mod:`.tool` down to the others; none of them imports :mod:`.tool`.
The package's own names are loaded on first use (PEP 562): importing one module of it (the QGIS plugin's
in-process ``outputs.accuracy_lines``, without rasterio) does not import the tool and its readers.
"""
__all__ = ["CAMERA_FILE", "FILES", "adjust_determined", "start_height", "triangulate"]


def __getattr__(name):
    if name in __all__:
        from . import tool
        return getattr(tool, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
