"""How often triangulate's inputs are opened and read: counts, not times (deterministic on any machine).

* ``block``: one :func:`fotogeo.tools.triangulate.match.block_tie_points` run (LSM on) on the rendered 2 x 4 block of
  ``tests/test_triangulate_ties.py`` (400 x 600 px frames), written as 3-band frames (``equal``) and with every other
  frame one band (``mixed``, the pairs across band sets of a NIR-only frame beside RGB ones): the calls of
  ``rasterio.open`` and the full-resolution frame reads of the least-squares matching
  (:func:`fotogeo.io.raster.read_decimated` asked for every pixel), beside the tie points found (a check that the
  results stay the same).
* ``exif``: the maker-note parses (EXIF block reads of :mod:`fotogeo.io.exif_sizes`) while reading the metadata of
  the eBee JPEGs in ``drone_snowpeak/img`` (Canon IXUS 125 HS) with :func:`fotogeo.io.exif.read_image_metadata`.

Printed as JSON and written to ``benchmarks/results/triangulate_reads_bench.json``.

    .venv/bin/python benchmarks/triangulate_reads_bench.py
"""
from __future__ import annotations

import collections
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import rasterio

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
sys.path.insert(0, str(ROOT / "tests"))


def block_counts(folder: Path) -> dict:
    from fotogeo.geometry.camera import FrameCamera
    from fotogeo.orientation.block_render import render_block
    from fotogeo.orientation.block_simulation import simulate_block
    from fotogeo.tools.triangulate import match, pairs
    from rendered_block_ties import write_frames
    cam = FrameCamera(6.0, (4.0, 6.0), (400, 600))
    sb = simulate_block(seed=1, strips=2, frames_per_strip=4, camera=cam, point_spacing=80.0, blunder_fraction=0.0,
                        margin=5.0)
    images, _ = render_block(sb)
    height = float(np.nanmean(sb.block.point_xyz[:, 2]))
    out = {}
    for kind in ("equal", "mixed"):
        frames = []
        for k, im in enumerate(images):
            im = im if im.ndim == 3 else im[None]
            rgb = np.concatenate([im, np.clip(im.astype(int) + 10, 0, 255).astype(np.uint8), im])
            frames.append(rgb if kind == "equal" or k % 2 == 0 else im)
        (folder / kind).mkdir()
        paths = write_frames(folder / kind, sb, frames)
        n = collections.Counter()
        real_open, real_read = rasterio.open, pairs.read_decimated

        def counted_open(*a, **k):
            n["rasterio_open"] += 1
            return real_open(*a, **k)

        def counted_read(info, max_pixels, *a, **k):
            n["full_resolution_reads"] += max_pixels > info.width * info.height
            return real_read(info, max_pixels, *a, **k)
        rasterio.open, pairs.read_decimated = counted_open, counted_read
        try:
            frame, track, pixel, _, rep = match.block_tie_points(paths, cam, sb.block.eo, height)
        finally:
            rasterio.open, pairs.read_decimated = real_open, real_read
        out[kind] = {**n, "observations": len(frame), "tracks": len(np.unique(track)),
                     "pixel_sum": round(float(pixel.sum()), 4), "lsm_converged": rep["lsm"]["converged"]}
    return out


def exif_counts() -> dict | None:
    from fotogeo.io import exif_sizes
    from fotogeo.io.exif import read_image_metadata
    frames = sorted((DATA / "drone_snowpeak" / "img").glob("*.JPG"))
    if not frames:
        return None
    reads, real = [], exif_sizes.exif_tiff
    exif_sizes.exif_tiff = lambda p: reads.append(p) or real(p)
    try:
        metas = [read_image_metadata(f) for f in frames]
    finally:
        exif_sizes.exif_tiff = real
    return {"frames": len(frames), "maker_note_parses": len(reads),
            "canon_focal": sorted({m.canon_focal for m in metas}, key=str),
            "written_sizes": sorted({m.written_sizes for m in metas}, key=str)}


def main():
    with tempfile.TemporaryDirectory() as tmp:
        result = {"block": block_counts(Path(tmp)), "exif": exif_counts()}
    print(json.dumps(result, indent=1, default=list))
    out = ROOT / "benchmarks" / "results" / "triangulate_reads_bench.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(result, indent=1, default=list) + "\n")


if __name__ == "__main__":
    main()
