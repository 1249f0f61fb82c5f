"""The PCA band-fusion tool: multi-band raster (path) → single-band first-component GeoTIFF.

Statistics come from a decimated read (at most ``sample_pixels``), then the component is
computed and written window by window, so memory stays bounded on large rasters. The
georeference is kept; invalid input pixels become nodata (-9999 for float32 output, 0 for
the 8-bit stretched output).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rasterio.windows import Window

from ...image.fusion import pca_fuse, valid_mask
from ...io.output_checks import check_output
from ...io.raster import AtomicOutputs, geotiff_profile, open_raster, read_decimated, ropen
from ...progress import as_progress
from ..common.boundary import tool


@tool("FUSE", rasters={"source": None})
def fuse_raster(source, output, *, stretch: bool = True, sample_pixels: int = 4_000_000, seed: int = 0,
                overwrite: bool = False, progress=None, block_rows: int = 512) -> dict:
    """Write the first principal component of ``source`` to ``output``.

    With ``stretch`` (default) the output is uint8 0..255 (robust 1–99 % stretch, 0 = nodata,
    valid pixels 1..255); without, float32 component values (nodata -9999). Returns a
    summary dict (component, explained variance, stretch).
    """
    prog = as_progress(progress)
    check_output(output, [source], overwrite)
    info = open_raster(source, "source")
    bands, mask, _ = read_decimated(info, sample_pixels, "source")
    stats = pca_fuse(bands, mask, nodata=info.nodata, sample=sample_pixels, rng=seed, name=f"source {source}")
    prog(0.1, "statistics")
    v = stats.component.astype(np.float64)
    lo, hi = stats.stretch
    # the mean used by pca_fuse: recompute from the same valid sample for the windowed pass
    valid = valid_mask(bands, mask, info.nodata)
    mean = bands.reshape(bands.shape[0], -1)[:, valid.ravel()].astype(np.float64).mean(axis=1)
    dtype, nodata = ("uint8", 0) if stretch else ("float32", -9999.0)
    with AtomicOutputs(overwrite) as out, ropen(info.path) as src:
        tmp = out.temp(output)
        prof = geotiff_profile(width=src.width, height=src.height, count=1, dtype=dtype, crs=src.crs,
                               transform=src.transform, nodata=nodata)
        with ropen(tmp, "w", **prof) as dst:
            for r0 in range(0, src.height, block_rows):
                win = Window(0, r0, src.width, min(block_rows, src.height - r0))
                data = src.read(window=win)
                ok = valid_mask(data, src.read_masks(window=win).min(axis=0) > 0, info.nodata)
                pc = np.tensordot(v, data.astype(np.float64) - mean[:, None, None], axes=1)
                if stretch:
                    res = np.clip(np.round(1 + (pc - lo) * 254.0 / (hi - lo)), 1, 255).astype(np.uint8)
                else:
                    res = pc.astype(np.float32)
                res[~ok] = nodata
                dst.write(res, 1, window=win)
                prog(0.1 + 0.9 * min(1.0, (r0 + block_rows) / src.height), "writing the first component")
            dst.update_tags(fotogeo_pca_component=",".join(f"{x:.6f}" for x in v),
                            fotogeo_pca_explained=f"{stats.explained:.6f}")
        out.commit()
    return {"output": str(Path(output)), "component": v.tolist(), "explained": stats.explained,
            "stretch": [lo, hi]}
