"""Nothing written beside the user's inputs: GDAL's PAM side files (``<raster>.aux.xml``) kept off.

A QGIS raster layer computes band statistics when it loads, and GDAL's Persistent Auxiliary Metadata
(PAM) saves them in ``<raster>.aux.xml`` beside the raster when the dataset closes. fotogeo's
algorithms need only the paths of their inputs (the worker reads the files itself), so:

- an input given as a file path is never loaded as a layer (:meth:`FotogeoAlgorithm.raster_path`,
  :meth:`FotogeoAlgorithm.layer_paths`, the parameter check);
- what has to be loaded still (a layer URI with options) loads inside :func:`no_side_files`, a
  thread-local ``GDAL_PAM_ENABLED=NO``: GDAL decides per dataset, at its first metadata access
  (the statistics of the load), whether PAM is on, and keeps that decision until it closes;
- ``qgis_process`` itself loads every raster parameter as a layer before an algorithm's code runs:
  when it runs a fotogeo algorithm (:func:`runs_fotogeo`), PAM is off for that process
  (:func:`guard_qgis_process`, called when the provider loads). Other algorithms and the desktop
  keep QGIS's behaviour: there PAM also reads georeferencing stored in ``.aux.xml`` files;
- the worker runs with ``GDAL_PAM_ENABLED=NO`` (:func:`processing_provider.runtime.worker_environment`).
"""
from __future__ import annotations

import contextlib
import os
import re

PAM = "GDAL_PAM_ENABLED"


def runs_fotogeo(arguments) -> bool:
    """Whether a command line is ``qgis_process … run fotogeo:<algorithm> …``."""
    args = [str(a) for a in arguments]
    if not args or not re.split(r"[\\/]", args[0])[-1].startswith("qgis_process"):  # / or \\ (Windows)
        return False
    try:
        alg = args[args.index("run") + 1]
    except (ValueError, IndexError):
        return False
    return alg.startswith("fotogeo:")


def guard_qgis_process(arguments=None) -> bool:
    """Turn GDAL PAM off for this process when it is ``qgis_process`` running a fotogeo algorithm
    (``arguments``: the process's command line [QCoreApplication's]); returns whether it did."""
    if arguments is None:
        from qgis.PyQt.QtCore import QCoreApplication
        arguments = QCoreApplication.arguments()
    if not runs_fotogeo(arguments):
        return False
    os.environ[PAM] = "NO"  # GDAL reads a config option it was not given from the environment, at each use
    with contextlib.suppress(ImportError):
        from osgeo import gdal
        gdal.SetConfigOption(PAM, "NO")
    return True


@contextlib.contextmanager
def no_side_files():
    """GDAL PAM off in this thread while layers load (no ``.aux.xml`` for the datasets opened inside)."""
    try:
        from osgeo import gdal
    except ImportError:  # without GDAL's bindings there is nothing to scope: the paths are never loaded
        yield
        return
    before = gdal.GetThreadLocalConfigOption(PAM, None)
    gdal.SetThreadLocalConfigOption(PAM, "NO")
    try:
        yield
    finally:
        gdal.SetThreadLocalConfigOption(PAM, before)
