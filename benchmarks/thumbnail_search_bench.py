"""The crop-width search of ``fotogeo.io.exif_thumbnail.thumbnail_view`` coarse to fine against every width, with
thumbnails of 160, 320 and 512 px (a phone's): CPU seconds and the box each finds.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/thumbnail_search_bench.py [--work /tmp/thumbnail_search_bench] [--out J]

Three eBee frames of ``drone_snowpeak`` (4608x3456; not the two the tests build with) stand for the camera's frame; the
thumbnail is that frame shrunk (INTER_AREA) to each width, given to ``thumbnail_view`` in place of the file's own. The
copies (grey JPEG, quality 92): resizes by 3/4, 1/2, 1/4 of the whole frame, and crops of 90 % centred, 80 % at the
corner then 1/2, 60 % off-centre then 0.37. Each copy is placed twice: coarse to fine (``SEARCH_WIDTH`` 160: the
widths one pixel apart at 160 px, then refined at the thumbnail's own width) and every width at the thumbnail's own
(``SEARCH_WIDTH`` above it: the search before). A table of CPU seconds and of the largest difference in box and
correlation between the two is printed; rows go to ``--out`` (default
``benchmarks/results/thumbnail_search_bench.json``).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "drone_snowpeak" / "img"
if not DATA.is_dir():
    DATA = Path("/work/shared/data/drone_snowpeak/img")
OUT = ROOT / "benchmarks" / "results" / "thumbnail_search_bench.json"
W, H = 4608, 3456
FRAMES = ("IMG_2189", "IMG_2213", "IMG_2282")
WIDTHS = (160, 320, 512)
#: (name, crop fraction, place of the crop in the room left, resize factor after it)
COPIES = (("resize 3/4", 1.0, (0, 0), 0.75), ("resize 1/2", 1.0, (0, 0), 0.5), ("resize 1/4", 1.0, (0, 0), 0.25),
          ("crop 90% centre", 0.9, (0.5, 0.5), 1.0), ("crop 80% corner then 1/2", 0.8, (0, 0), 0.5),
          ("crop 60% off-centre then 0.37", 0.6, (0.8, 0.3), 0.37))


def main(argv=None) -> int:
    import cv2

    import fotogeo.io.exif_thumbnail as et
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/thumbnail_search_bench"))
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    a.work.mkdir(parents=True, exist_ok=True)
    rows, reader, search = [], et._thumbnail, et.SEARCH_WIDTH
    try:
        for frame in FRAMES:
            img = cv2.imread(str(DATA / f"{frame}.JPG"), cv2.IMREAD_GRAYSCALE)
            for tw in WIDTHS:
                thumb = cv2.resize(img, (tw, tw * 3 // 4), interpolation=cv2.INTER_AREA)
                et._thumbnail = lambda path, t=thumb: t
                for name, c, (px, py), k in COPIES:
                    cw, ch = round(W * c), round(H * c)
                    x0, y0 = round((W - cw) * px), round((H - ch) * py)
                    part = cv2.resize(img[y0:y0 + ch, x0:x0 + cw], (round(cw * k), round(ch * k)),
                                      interpolation=cv2.INTER_AREA)
                    dst = a.work / f"{frame}.jpg"
                    cv2.imwrite(str(dst), part, [cv2.IMWRITE_JPEG_QUALITY, 92])
                    got = {}
                    for mode, width in (("coarse_to_fine", search), ("every_width", 10 ** 6)):
                        et.SEARCH_WIDTH = width
                        t0 = time.process_time()
                        v = et.thumbnail_view(dst, (W, H))
                        got[mode] = {"cpu_s": round(time.process_time() - t0, 3), "r_resize": round(v.r_resize, 3),
                                     "r_crop": round(v.r_crop, 3), "at": v.at, "crop": v.crop}
                    rows.append({"frame": frame, "thumbnail": tw, "copy": name, "box": (x0, y0, cw, ch), **got})
                    f, e = got["coarse_to_fine"], got["every_width"]
                    print(f"{frame} {tw:3d} px {name:30s} coarse-to-fine {f['cpu_s']:.2f} s r {f['r_crop']:.3f} "
                          f"{f['at']} {f['crop']} | every width {e['cpu_s']:.2f} s r {e['r_crop']:.3f} {e['at']} "
                          f"{e['crop']}", flush=True)
    finally:
        et._thumbnail, et.SEARCH_WIDTH = reader, search
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(rows, indent=1))
    print("\n| thumbnail | copies | CPU s coarse-to-fine (median, max) | CPU s every width (median, max) | "
          "box apart max (frame px) | r_crop lower max |")
    print("|---|---|---|---|---|---|")
    for tw in WIDTHS:
        got = [r for r in rows if r["thumbnail"] == tw]
        f = sorted(r["coarse_to_fine"]["cpu_s"] for r in got)
        e = sorted(r["every_width"]["cpu_s"] for r in got)
        apart = max(max(abs(p - q) for p, q in zip(r["coarse_to_fine"]["at"] + r["coarse_to_fine"]["crop"],
                                                    r["every_width"]["at"] + r["every_width"]["crop"])) for r in got)
        lower = max(r["every_width"]["r_crop"] - r["coarse_to_fine"]["r_crop"] for r in got)
        print(f"| {tw} px | {len(got)} | {f[len(f) // 2]:.2f}, {f[-1]:.2f} | {e[len(e) // 2]:.2f}, {e[-1]:.2f} | "
              f"{apart} | {lower:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
