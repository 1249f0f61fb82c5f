"""A 448 × 600 px crop of the Landsat clip and the clip itself: a co-registration whose overlap is the crop."""
from __future__ import annotations

import shutil


def patch_pair(data_dir, folder):
    """``(reference, target)``: copies of the Landsat clip and of its top-left 448 × 600 px (nothing else written)."""
    import rasterio
    from rasterio.windows import Window
    reference = folder / "reference.tif"
    shutil.copy(data_dir / "landsat_rgb" / "RGB.byte.tif", reference)
    target = folder / "patch.tif"
    with rasterio.open(reference) as ds:
        window = Window(0, 0, 448, 600)
        profile = {**ds.profile, "width": 448, "height": 600, "transform": ds.window_transform(window)}
        data = ds.read(window=window)
    with rasterio.open(target, "w", **profile) as out:
        out.write(data)
    return reference, target
