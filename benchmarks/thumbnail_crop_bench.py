"""Crops, resizes and crops then resized of the eBee frames, with their EXIF (and thumbnail) and XMP kept: what the
camera reader (``fotogeo.io.exif_camera.focal_of``) makes of each, against the truth the copy was built with.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/thumbnail_crop_bench.py [--work /tmp/thumbnail_crop_bench] [--out J]

The 8 frames of ``drone_snowpeak`` (4608x3456, EXIF thumbnail 160x120) are copied with OpenCV (INTER_AREA, JPEG
quality 92, both APP1 segments kept as ``tests/jpeg_metadata.resized_copy`` does) as: a resize of the whole frame by
1/2, 1/3, 1/4, 0.37, 0.6, 1/8, 1/16 and 0.99 (truth: accepted, focal length the original's times the factor), and a
crop of 90, 80 or 60 % of the frame's width and height at its centre, its top-left corner or off-centre (at 80 % and
30 % of the room left on each axis), kept at full size or resized by 1/2, 1/3, 1/4 or 0.37 (truth: refused — the
camera of a crop is not in its tags). Each row: the verdict (``ok`` with the focal length, or the refusal's kind:
``crop`` "cropped, not resized", ``crop+resize`` "cropped to … and resized by …", ``no-match`` the thumbnail matches
neither as a whole nor anywhere, ``uneven`` the size is no resize of the frame to the pixel, ``other``), and
``thumbnail_view``'s correlations, box and the resize factor the box implies. A table of verdict counts per kind of
copy is printed; rows go to ``--out`` (default ``benchmarks/results/thumbnail_crop_bench.json``).
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "drone_snowpeak" / "img"
if not DATA.is_dir():
    DATA = Path("/work/shared/data/drone_snowpeak/img")
OUT = ROOT / "benchmarks" / "results" / "thumbnail_crop_bench.json"
W, H = 4608, 3456
RESIZES = (1 / 2, 1 / 3, 1 / 4, 0.37, 0.6, 1 / 8, 1 / 16, 0.99)
CROPS = (0.9, 0.8, 0.6)
PLACES = {"centre": (0.5, 0.5), "top-left": (0.0, 0.0), "off-centre": (0.8, 0.3)}
CROP_RESIZES = (1.0, 1 / 2, 1 / 3, 1 / 4, 0.37)


def _copy(data: bytes, img, box, factor, dst: Path) -> Path:
    import cv2
    x0, y0, x1, y1 = box
    part = img[y0:y1, x0:x1]
    if factor != 1:
        part = cv2.resize(part, (round(part.shape[1] * factor), round(part.shape[0] * factor)),
                          interpolation=cv2.INTER_AREA)
    enc = cv2.imencode(".jpg", part, [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes()
    segments, i = [], 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:
        n = int.from_bytes(data[i + 2:i + 4], "big")
        if data[i + 1] == 0xE1:
            segments.append(data[i:i + 2 + n])
        i += 2 + n
    dst.write_bytes(b"\xff\xd8" + b"".join(segments) + enc[2:])
    return dst


def _verdict(path: Path) -> tuple:
    from fotogeo.errors import InputError
    from fotogeo.io.exif import read_image_metadata
    from fotogeo.io.exif_camera import focal_of
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return "ok", focal_of(read_image_metadata(path))[0], ""
        except InputError as e:
            msg = str(e)
    kind = ("crop+resize" if "and resized by about" in msg else "crop" if "cropped, not resized" in msg else
            "no-match" if "neither as a whole" in msg else "uneven" if "not the file's size times one factor" in msg
            else "other")
    return kind, None, msg


def main(argv=None) -> int:
    import cv2
    import numpy as np
    try:
        from fotogeo.io.exif_thumbnail import thumbnail_view
    except ImportError:  # a tree before it (the verdicts only, for a before/after table)
        def thumbnail_view(path, full):
            return None
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/thumbnail_crop_bench"))
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    a.work.mkdir(parents=True, exist_ok=True)
    rows = []
    for src in sorted(DATA.glob("*.JPG")):
        data = src.read_bytes()
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        f0 = _verdict(src)[1]
        cases = [("resize", f"resize {k:.4g}", (0, 0, W, H), k) for k in RESIZES]
        for c in CROPS:
            cw, ch = round(W * c), round(H * c)
            for place, (px, py) in PLACES.items():
                x0, y0 = round((W - cw) * px), round((H - ch) * py)
                cases += [("crop" if k == 1 else "crop+resize", f"crop {c:.0%} {place} then {k:.4g}",
                           (x0, y0, x0 + cw, y0 + ch), k) for k in CROP_RESIZES]
        for kind, name, box, k in cases:
            dst = _copy(data, img, box, k, a.work / f"{src.stem}.JPG")
            verdict, f, msg = _verdict(dst)
            v = thumbnail_view(dst, (W, H))
            rows.append({"frame": src.stem, "kind": kind, "case": name, "box": box, "factor": k, "verdict": verdict,
                         "focal_px": f, "focal_true_px": f0 * k if kind == "resize" else None,
                         "message": msg[:400],
                         "thumbnail": None if v is None else {
                             "r_resize": round(v.r_resize, 3), "r_crop": round(v.r_crop, 3), "at": v.at,
                             "crop": v.crop, "implied_factor": round(cv2.imread(str(dst), 0).shape[1] / v.crop[0], 4)}})
            print(f"{src.stem} {name:32s} {verdict:12s} "
                  + ("" if v is None else f"r_resize {v.r_resize:.3f} r_crop {v.r_crop:.3f} box {v.at} {v.crop}"),
                  flush=True)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(rows, indent=1))
    print("\n| copy | n | ok | crop | crop+resize | no-match | uneven | other | focal error max |")
    print("|---|---|---|---|---|---|---|---|---|")
    for kind in ("resize", "crop", "crop+resize"):
        got = [r for r in rows if r["kind"] == kind]
        err = [abs(r["focal_px"] / r["focal_true_px"] - 1) for r in got if r["focal_px"] and r["focal_true_px"]]
        counts = [sum(r["verdict"] == v for r in got) for v in ("ok", "crop", "crop+resize", "no-match", "uneven",
                                                                 "other")]
        print(f"| {kind} | {len(got)} | " + " | ".join(map(str, counts)) + f" | {max(err, default=0):.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
