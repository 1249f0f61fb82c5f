"""The image to pick on, shown in pixel units: x = col, y = −row, as the Georeferencer and ``.points`` do.

A georeferenced image would otherwise be drawn in its map CRS, so the picker shows a GDAL VRT of
it (in a temporary folder, never beside the input) whose geotransform is ``(0, 1, 0, 0, 0, −1)``
and which has no CRS: map coordinate (x, y) of that layer is pixel (col, row) = (x, −y), with
(0, 0) the top-left corner of the top-left pixel (GDAL's corner convention, fotogeo's). QGIS reads
the VRT with its own GDAL; any number of bands works (QGIS's default renderer). A large image
without overviews gets overviews of the VRT built in a :class:`QgsTask` (QGIS then draws from
them: zooming out never reads every pixel, the GUI never waits on them).
"""
from __future__ import annotations

import os
import shutil
import tempfile

from qgis.core import QgsApplication, QgsRasterLayer, QgsTask

from fotogeo.image_extent import on_image, outside_reason  # standard library only

#: pixels above which an image without overviews gets them (rendering then reads the pyramids)
OVERVIEW_PIXELS = 4000 * 4000


class ImageError(ValueError):
    """The chosen image cannot be used; the message names it and the fix."""


def pixel_vrt(path: str, folder: str) -> tuple[str, int, int, bool]:
    """``(vrt path, width, height, has overviews)`` of ``path`` in pixel units (module docstring)."""
    from osgeo import gdal
    gdal.UseExceptions()
    try:
        src = gdal.Open(path)
    except RuntimeError as e:
        raise ImageError(f"image {path!r} is not a raster GDAL can read ({str(e).strip()}); choose an image file "
                         f"(GeoTIFF, JPEG, …)") from None
    if src is None or src.RasterCount == 0:
        raise ImageError(f"image {path!r} holds no raster bands; choose an image file (GeoTIFF, JPEG, …)")
    width, height = src.RasterXSize, src.RasterYSize
    has_overviews = src.GetRasterBand(1).GetOverviewCount() > 0
    vrt = os.path.join(folder, os.path.splitext(os.path.basename(path))[0] + "_pixels.vrt")
    out = gdal.Translate(vrt, src, format="VRT")
    out.SetGeoTransform((0.0, 1.0, 0.0, 0.0, 0.0, -1.0))
    out.SetProjection("")
    if out.GetGCPCount():
        out.SetGCPs([], "")
    out.FlushCache()
    out = src = None
    return vrt, width, height, has_overviews


class OverviewTask(QgsTask):
    """Builds overviews of the picker's VRT (not of the input) so QGIS draws a huge image from pyramids."""

    def __init__(self, vrt: str, on_done):
        super().__init__(f"fotogeo picker: pyramids of {os.path.basename(vrt)}", QgsTask.CanCancel)
        self.vrt, self.on_done, self.error = vrt, on_done, None

    def run(self):
        from osgeo import gdal
        gdal.UseExceptions()

        def progress(fraction, message, data):
            self.setProgress(100.0 * fraction)
            return 0 if self.isCanceled() else 1
        try:
            ds = gdal.Open(self.vrt)
            ds.BuildOverviews("AVERAGE", [2, 4, 8, 16, 32], callback=progress)
            ds = None
        except RuntimeError as e:
            self.error = str(e)
            return False
        return True

    def finished(self, ok):
        self.on_done(ok, self.error)


class PickerImage:
    """The picker's image: the source path, its size and the pixel-unit layer the image canvas shows."""

    def __init__(self, path: str, on_overviews=None):
        self.path = path
        self.folder = tempfile.mkdtemp(prefix="fotogeo-picker-")
        self.vrt, self.width, self.height, has_overviews = pixel_vrt(path, self.folder)
        options = QgsRasterLayer.LayerOptions()
        options.skipCrsValidation = True  # the pixel grid has no CRS: do not ask the user for one
        self.layer = QgsRasterLayer(self.vrt, os.path.basename(path), "gdal", options)
        if not self.layer.isValid():
            raise ImageError(f"QGIS cannot display image {path!r}: {self.layer.error().summary()}")
        self.task = None
        if not has_overviews and self.width * self.height > OVERVIEW_PIXELS:
            self.task = OverviewTask(self.vrt, lambda ok, error: (self.layer.reload(), self.layer.triggerRepaint(),
                                                                  on_overviews and on_overviews(ok, error)))
            QgsApplication.taskManager().addTask(self.task)

    def close(self):
        """Forget the pixel layer and delete the temporary VRT (and its pyramids); an overview task is cancelled."""
        if self.task is not None:
            try:
                self.task.cancel()
            except RuntimeError:  # the task has finished and QGIS deleted it
                pass
        self.layer = None
        shutil.rmtree(self.folder, ignore_errors=True)

    @staticmethod
    def to_pixel(x: float, y: float) -> tuple[float, float]:
        """Image canvas coordinates → (col, row)."""
        return x, -y

    @staticmethod
    def to_canvas(col: float, row: float) -> tuple[float, float]:
        """(col, row) → image canvas coordinates."""
        return col, -row

    def inside(self, col: float, row: float) -> bool:
        """The click guard: :func:`fotogeo.image_extent.on_image` (edges included), the rule by which the worker
        flags a GCP off the image in the table (:func:`fotogeo.io.gcps.outside_image`)."""
        return bool(on_image(col, row, self.width, self.height))

    def outside(self) -> str:
        """The wording of a position off this image (:func:`fotogeo.image_extent.outside_reason`)."""
        return outside_reason(self.width, self.height)
