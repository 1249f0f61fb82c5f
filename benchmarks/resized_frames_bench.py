"""Resized drone frames: `fotogeo triangulate` on copies of the eBee flight made the ways users resize.

Run:  PYTHONPATH=. .venv/bin/python benchmarks/resized_frames_bench.py [--work /tmp/resized_frames_bench] [--tree T]
      [--cases '1/2, EXIF rewritten + XMP' ...] [--frames IMG_2280 IMG_2281 IMG_2282]

The 8 eBee frames of ``drone_snowpeak`` (see :mod:`dsm_heldout_bench`'s ``ebee`` group) are copied whole and
downsampled by OpenCV (INTER_AREA) to 1/2 and 1/4 (some sets 1/3 and 0.6) with

* ``EXIF only`` — the original's EXIF APP1 segment and no XMP (what PIL's ``save(exif=im.info["exif"])`` leaves:
  ``PixelXDimension`` still 4608, the senseFly XMP attitude and GPS accuracy gone);
* ``EXIF + XMP`` — both APP1 segments as they were (a tool that copies the metadata);
* ``no metadata`` — ``cv2.imwrite`` alone (no EXIF: no GPS, no focal length);
* ``EXIF rewritten + XMP`` — ``PixelXDimension``/``PixelYDimension`` set to the new size, the rest (the full
  frame's ``FocalPlaneXResolution``, the Interoperability IFD's ``RelatedImageWidth`` and Canon's maker note, which
  record the camera's 4608x3456) and the XMP as they were; ``EXIF and RelatedImageWidth rewritten`` also sets
  ``RelatedImageWidth``/``Length``; ``every size rewritten, no maker note`` also drops the maker note, so that
  nothing in the files records the size the camera wrote (only the residual check of
  :mod:`fotogeo.tools.triangulate.exif_focal` is left); ``FocalLengthIn35mmFilm added`` writes the camera's
  published 35 mm equivalent (24 mm), which the IXUS does not write but most cameras do: with it,
  ``FocalPlaneXResolution`` over the sensor it implies records the camera's frame (:mod:`fotogeo.io.exif_camera`).
  ``full size`` and ``1/2, EXIF + XMP`` with the tag added check that it does not refuse a right file.

Each set is triangulated from its files alone (``fotogeo triangulate *.JPG -o all``). For the sets that orient,
every frame's centre and PATB angles are compared with the full-size run's (max over the common frames) and with
the full-size run's own σ, and the image points' σ₀ with least-squares matching's σ is kept (the residual check of
:mod:`fotogeo.tools.triangulate.exif_focal`). Rows go to ``benchmarks/results/resized_frames_bench.json`` (CPU s =
user + sys); ``--cases`` runs only some sets and ``--frames`` a subset of the frames (their rows replace or join the
JSON's).
"""
from __future__ import annotations

import argparse
import json
import os
import struct
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import dsm_heldout_bench as hb  # noqa: E402

OUT = hb.ROOT / "benchmarks" / "results" / "resized_frames_bench.json"
SETS = {"full size": (1, "exif+xmp"), "1/2, EXIF only": (1 / 2, "exif"), "1/2, EXIF + XMP": (1 / 2, "exif+xmp"),
        "1/4, EXIF only": (1 / 4, "exif"), "1/4, EXIF + XMP": (1 / 4, "exif+xmp"), "1/2, no metadata": (1 / 2, "none"),
        "1/2, EXIF rewritten + XMP": (1 / 2, "rewritten"), "1/4, EXIF rewritten + XMP": (1 / 4, "rewritten"),
        "1/3, EXIF + XMP": (1 / 3, "exif+xmp"), "0.6, EXIF + XMP": (0.6, "exif+xmp"),
        "1/3, EXIF rewritten + XMP": (1 / 3, "rewritten"), "0.6, EXIF rewritten + XMP": (0.6, "rewritten"),
        "1/2, EXIF and RelatedImageWidth rewritten + XMP": (1 / 2, "rewritten+related"),
        "1/2, every size rewritten, no maker note + XMP": (1 / 2, "rewritten+related-makernote"),
        "1/4, every size rewritten, no maker note + XMP": (1 / 4, "rewritten+related-makernote"),
        "full size, FocalLengthIn35mmFilm added": (1, "exif+xmp+f35"),
        "1/2, EXIF + XMP, FocalLengthIn35mmFilm added": (1 / 2, "exif+xmp+f35"),
        "1/2, every size rewritten, no maker note, FocalLengthIn35mmFilm added + XMP":
            (1 / 2, "rewritten+related-makernote+f35"),
        "1/4, every size rewritten, no maker note, FocalLengthIn35mmFilm added + XMP":
            (1 / 4, "rewritten+related-makernote+f35"),
        "0.6, every size rewritten, no maker note, FocalLengthIn35mmFilm added + XMP":
            (0.6, "rewritten+related-makernote+f35")}
#: the IXUS 125 HS's published 35 mm equivalent at 4.3 mm (its FocalPlaneXResolution over 4608 px gives 24.1 mm),
#: which the camera does not write: ``FocalLengthIn35mmFilm added`` writes it, as DJI cameras and phones do
F35_MM = 24


def _copy(src: Path, dst: Path, scale: float, keep: str) -> Path:
    import cv2
    data = src.read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if scale < 1:
        size = (round(img.shape[1] * scale), round(img.shape[0] * scale))
        img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    enc = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes()
    segs, i = [], 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:
        n = struct.unpack(">H", data[i + 2:i + 4])[0]
        exif = data[i + 4:i + 10] == b"Exif\0\0"
        if data[i + 1] == 0xE1 and (keep != "none" and (exif or keep != "exif")):
            rewrite = exif and (keep.startswith("rewritten") or keep.endswith("+f35"))
            segs.append(_rewritten(data[i:i + 2 + n], img.shape, keep) if rewrite else data[i:i + 2 + n])
        i += 2 + n
    dst.write_bytes(b"\xff\xd8" + b"".join(segs) + enc[2:])
    return dst


def _rewritten(segment: bytes, shape, keep: str = "rewritten") -> bytes:
    """The EXIF APP1 ``segment`` with ``PixelXDimension``/``PixelYDimension`` set to the resized size (what a tool
    that updates them leaves; ``FocalPlaneXResolution`` still describes the full-resolution frame); with
    ``+related`` the Interoperability IFD's ``RelatedImageWidth``/``Length`` too, with ``-makernote`` the maker
    note dropped (nothing in the file then records the camera's size), with ``+f35`` FocalLengthIn35mmFilm added
    (:data:`F35_MM`; then ``FocalPlaneXResolution`` over the sensor it implies still records the camera's size)."""
    from PIL import Image
    ex = Image.Exif()
    ex.load(segment[4:])
    ifd = ex.get_ifd(0x8769)
    if keep.startswith("rewritten"):
        ifd[0xA002], ifd[0xA003] = int(shape[1]), int(shape[0])
    if keep.endswith("+f35"):
        ifd[0xA405] = F35_MM
    if "+related" in keep:
        interop = ex.get_ifd(0xA005)
        interop[0x1001], interop[0x1002] = int(shape[1]), int(shape[0])
    if "-makernote" in keep:
        ifd.pop(0x927C, None)
    body = ex.tobytes()
    body = body if body.startswith(b"Exif") else b"Exif\0\0" + body
    return b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body


def _orientation(folder: Path) -> dict:
    sys.path.insert(0, str(hb.TREE))
    from fotogeo.io.camera import read_exterior_orientation
    return read_exterior_orientation(folder / "exterior_orientation.txt")


def _image_sigma0(report: Path) -> float | None:
    """The image group's σ₀ with least-squares matching's σ (what :mod:`fotogeo.tools.triangulate.exif_focal`
    checks)."""
    image = json.loads(report.read_text())["statistics"]["variance_components"]["image"]
    s0 = image.get("sigma0_given", image.get("sigma0"))
    return round(s0, 2) if s0 is not None else None


def _versus(eo: dict, ref: dict, ref_report: dict) -> dict:
    common = sorted(set(eo) & set(ref))
    dc = [float(np.linalg.norm(eo[n].centre - ref[n].centre)) for n in common]
    da = [max(abs((getattr(eo[n], k) - getattr(ref[n], k) + 180) % 360 - 180) for k in ("omega", "phi", "kappa"))
          for n in common]
    sig = {f["name"]: f.get("sigma") or {} for f in ref_report.get("frames", [])}
    pos = [max(sig[n].get(k, np.nan) for k in ("X0", "Y0", "Z0")) for n in common if n in sig]
    ang = [max(sig[n].get(k, np.nan) for k in ("rx_deg", "ry_deg", "rz_deg")) for n in common if n in sig]
    return {"frames_oriented": len(eo), "common_with_full_size": len(common),
            "max_centre_diff_m": round(max(dc), 3) if dc else None,
            "max_angle_diff_deg": round(max(da), 3) if da else None,
            "full_size_max_position_sigma_m": round(max(pos), 2) if pos else None,
            "full_size_max_angle_sigma_deg": round(max(ang), 2) if ang else None}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/resized_frames_bench", help="copies and runs go here (reused)")
    ap.add_argument("--tree", default=str(hb.ROOT), help="the fotogeo checkout measured")
    ap.add_argument("--cases", nargs="+", choices=list(SETS), default=list(SETS),
                    help="only these sets ('full size', the reference, is always run first)")
    ap.add_argument("--frames", nargs="+", default=hb.EBEE, help="a subset of the 8 eBee frames (the cases' labels "
                    "then name them, their rows kept beside the 8-frame ones)")
    ap.add_argument("--out", default=str(OUT), help="the JSON the rows go to")
    a = ap.parse_args()
    hb.TREE = Path(a.tree).resolve()
    src = hb.DATA / "drone_snowpeak" / "img"
    if not src.is_dir():
        sys.exit(f"no drone_snowpeak in {hb.DATA}")
    rows, ref, ref_report = [], None, {}
    for label in ["full size", *(c for c in a.cases if c != "full size")]:
        factor, keep = SETS[label]
        tag = "" if a.frames == hb.EBEE else f" ({' '.join(a.frames)})"
        folder = Path(a.work).resolve() / (label + tag).replace("/", "_").replace(" ", "").replace(",", "_")
        folder.mkdir(parents=True, exist_ok=True)
        imgs = [_copy(src / f"{n}.JPG", folder / f"{n}.JPG", factor, keep) for n in a.frames]
        cmd = hb.PY + ["triangulate", *imgs, "-o", folder / "all", "--overwrite", "-q"]
        row = {"case": label + tag, **hb.time_v(cmd, folder), "command": hb._command(cmd, folder)}
        if row["exit"] == 0:
            row["image_sigma0_with_matcher_sigma"] = _image_sigma0(folder / "all" / "report.json")
            eo = _orientation(folder / "all")
            if ref is None:
                ref, ref_report = eo, json.loads((folder / "all" / "report.json").read_text())
                row["frames_oriented"] = len(eo)
            else:
                row.update(_versus(eo, ref, ref_report))
        rows.append(row)
        print(row, flush=True)
    stamp = {"load_average": round(os.getloadavg()[0], 1), **({} if hb.TREE == hb.ROOT else {"tree": str(hb.TREE)})}
    new = {r["case"]: {**r, **stamp} for r in rows}
    partial = a.cases != list(SETS) or a.frames != hb.EBEE
    out = Path(a.out)
    old = json.loads(out.read_text())["rows"] if out.exists() and partial else []
    kept = [r for r in old if r["case"] not in new]
    out.write_text(json.dumps({"rows": kept + list(new.values())}, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
