"""The residual check of a focal length from EXIF FocalPlaneXResolution on eBee pairs, triples and the 8 frames.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/exif_focal_pair_bench.py [--work /tmp/exif_focal_pair_bench]
      [--tree T] [--sets 2280/2281 ...]

The 8 eBee frames of ``drone_snowpeak`` as they are and as 1/2 and 1/4 copies with ``PixelXDimension`` rewritten
and ``RelatedImageWidth`` and the maker note dropped (:mod:`resized_frames_bench`'s ``every size rewritten, no maker
note``: nothing in the files records the camera's size, the focal length read is 2 or 4 times too long). Each set is
triangulated from its files alone (``fotogeo triangulate … -o out -q``); a row keeps the exit, the refusal, the image
group's σ₀ with least-squares matching's σ, the σ₀ of the hypotheses ``f/k`` (report.json's
``statistics.focal_hypotheses``, where the check ran them) and whether the run warned
(``statistics.focal_length_check``; :mod:`fotogeo.tools.triangulate.exif_focal`). Rows go to
``benchmarks/results/exif_focal_pair_bench.json`` (CPU s = user + sys).
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import dsm_heldout_bench as hb  # noqa: E402
import resized_frames_bench as rb  # noqa: E402

OUT = hb.ROOT / "benchmarks" / "results" / "exif_focal_pair_bench.json"
SETS = {"2280/2281": ["IMG_2280", "IMG_2281"], "2281/2282": ["IMG_2281", "IMG_2282"],
        "2280/2282": ["IMG_2280", "IMG_2282"], "2212/2213": ["IMG_2212", "IMG_2213"],
        "2186/2188": ["IMG_2186", "IMG_2188"], "2188/2189": ["IMG_2188", "IMG_2189"],
        "2280-2282": ["IMG_2280", "IMG_2281", "IMG_2282"], "2186-2189": ["IMG_2186", "IMG_2188", "IMG_2189"],
        "8 frames": hb.EBEE}
SCALES = {"full": 1, "1/2": 1 / 2, "1/4": 1 / 4}


def _copies(work: Path) -> dict:
    src = hb.DATA / "drone_snowpeak" / "img"
    out = {}
    for label, factor in SCALES.items():
        if factor == 1:  # the originals, read only
            out[label] = src
            continue
        folder = work / "copies" / label.replace("/", "_")
        folder.mkdir(parents=True, exist_ok=True)
        for n in hb.EBEE:
            if not (folder / f"{n}.JPG").exists():
                rb._copy(src / f"{n}.JPG", folder / f"{n}.JPG", factor, "rewritten+related-makernote")
        out[label] = folder
    return out


def _row(folder: Path, frames: list, out: Path) -> dict:
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = hb.PY + ["triangulate", *[folder / f"{n}.JPG" for n in frames], "-o", out, "--overwrite", "-q"]
    row = hb.time_v(cmd, out.parent)
    m = re.search(r"residuals are ([\d.]+) times", row.get("message", ""))
    if m:
        row["sigma0"] = float(m.group(1))
    if row["exit"] == 0:
        stats = json.loads((out / "report.json").read_text())["statistics"]
        image = stats["variance_components"]["image"]
        row["sigma0"] = round(image.get("sigma0_given", image.get("sigma0")), 2)
        row["hypotheses"] = stats.get("focal_hypotheses")
        row["warned"] = "focal_length_check" in stats
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/exif_focal_pair_bench", help="copies and runs go here (reused)")
    ap.add_argument("--tree", default=str(hb.ROOT), help="the fotogeo checkout measured")
    ap.add_argument("--sets", nargs="+", choices=list(SETS), default=list(SETS))
    ap.add_argument("--out", default=str(OUT), help="the JSON the rows go to")
    a = ap.parse_args()
    hb.TREE = Path(a.tree).resolve()
    if not (hb.DATA / "drone_snowpeak" / "img").is_dir():
        sys.exit(f"no drone_snowpeak in {hb.DATA}")
    work = Path(a.work).resolve()
    copies, rows = _copies(work), []
    print("| frames | size | exit | σ₀ | σ₀ of f/k | warned | CPU s |\n|---|---|---|---|---|---|---|")
    for name in a.sets:
        for label, folder in copies.items():
            out = work / "runs" / f"{name}_{label}".replace("/", "_").replace(" ", "_")
            row = {"set": name, "size": label, **_row(folder, SETS[name], out)}
            rows.append(row)
            print(f"| {name} | {label} | {row['exit']} | {row.get('sigma0', '–')} | {row.get('hypotheses') or '–'} | "
                  f"{row.get('warned', '–')} | {row['cpu_s']} |", flush=True)
    Path(a.out).write_text(json.dumps({"tree": str(hb.TREE), "rows": rows}, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
