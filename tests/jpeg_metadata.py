"""Edit the metadata of a real JPEG's bytes for bad-input tests: the XMP packet (APP1 ``http://ns.adobe.com/xap/1.0/``),
an IFD0 tag of the EXIF segment (APP1 ``Exif``), an EXIF text. The image data is never touched, so the copy
is still the camera's file but for the one fact changed. No exiftool or piexif needed: the segments are
walked by their markers (JPEG, ITU-T T.81 B.1.1.2) and the EXIF IFD0 by its TIFF header (EXIF 2.3 §4.5)."""
from __future__ import annotations

import shutil
import struct
from pathlib import Path

XMP_ID = b"http://ns.adobe.com/xap/1.0/\x00"


def _app1(data: bytes, ident: bytes) -> tuple[int, int]:
    """``(start of the payload, end of the segment)`` of the APP1 segment whose payload starts with ``ident``."""
    i = 2  # after SOI
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:  # up to the scan
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if data[i + 1] == 0xE1 and data[i + 4:i + 4 + len(ident)] == ident:
            return i + 4, i + 2 + length
        i += 2 + length
    raise ValueError(f"no APP1 {ident[:20]!r} segment")


def xmp_of(path) -> str:
    data = Path(path).read_bytes()
    start, end = _app1(data, XMP_ID)
    return data[start + len(XMP_ID):end].decode("utf-8")


def write_xmp(path, packet: str) -> None:
    """Replace the XMP packet of the JPEG ``path`` (the segment's length updated)."""
    data = Path(path).read_bytes()
    start, end = _app1(data, XMP_ID)
    payload = XMP_ID + packet.encode("utf-8")
    head = start - 4
    Path(path).write_bytes(data[:head] + b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload + data[end:])


def _ifd_entries(data, order: str, tiff: int, ifd: int):
    """``(tag, offset of the entry)`` of the IFD at ``ifd`` (offset in ``data``)."""
    count = struct.unpack(order + "H", data[ifd:ifd + 2])[0]
    for k in range(count):
        at = ifd + 2 + 12 * k
        yield struct.unpack(order + "H", data[at:at + 2])[0], at


def _entry(path, tag: int, exif_ifd: bool):
    """``(data, byte order, offset of the entry)`` of the IFD0 (or Exif sub-IFD) entry ``tag`` of ``path``."""
    data = bytearray(Path(path).read_bytes())
    start, _ = _app1(bytes(data), b"Exif\x00\x00")
    tiff = start + 6
    order = "<" if data[tiff:tiff + 2] == b"II" else ">"
    ifd = tiff + struct.unpack(order + "I", data[tiff + 4:tiff + 8])[0]
    if exif_ifd:
        at = next(a for t, a in _ifd_entries(data, order, tiff, ifd) if t == 0x8769)
        ifd = tiff + struct.unpack(order + "I", data[at + 8:at + 12])[0]
    for t, at in _ifd_entries(data, order, tiff, ifd):
        if t == tag:
            return data, order, at
    raise ValueError(f"{path}: no {'Exif IFD' if exif_ifd else 'IFD0'} tag 0x{tag:04x}")


def rename_ifd0_tag(path, tag: int, new_tag: int, *, exif_ifd: bool = False) -> None:
    """Give the IFD0 entry ``tag`` the number ``new_tag`` (e.g. GPSInfo 0x8825 -> a private tag: no GPS); with
    ``exif_ifd``, the entry of the Exif sub-IFD (pointed to by IFD0's 0x8769; e.g. PixelXDimension 0xA002)."""
    data, order, at = _entry(path, tag, exif_ifd)
    data[at:at + 2] = struct.pack(order + "H", new_tag)
    Path(path).write_bytes(bytes(data))


def set_integer_tag(path, tag: int, value: int, *, exif_ifd: bool = False) -> None:
    """Set the one-value SHORT or LONG entry ``tag`` (stored in the entry itself) to ``value``, e.g. the Exif
    IFD's PixelXDimension 0xA002 rewritten to a resized size (what Photoshop/Lightroom exports leave)."""
    data, order, at = _entry(path, tag, exif_ifd)
    kind = struct.unpack(order + "H", data[at + 2:at + 4])[0]
    data[at + 8:at + 12] = (struct.pack(order + "HH", value, 0) if kind == 3 else struct.pack(order + "I", value))
    Path(path).write_bytes(bytes(data))


def resized_copy(src, dst, factor: float, *, xmp: bool = True) -> Path:
    """``src`` downsampled by ``factor`` (OpenCV, area averaging) into the JPEG ``dst`` with the original's APP1
    segments (EXIF, XMP) as they were — what a resizing tool that keeps the metadata leaves: the EXIF
    PixelXDimension and the calibration tags still describe the full-resolution frame. ``xmp=False``: the EXIF
    only (PIL's ``save(exif=im.info["exif"])`` drops the XMP packet so)."""
    import cv2
    import numpy as np
    data = Path(src).read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    small = cv2.resize(img, (round(img.shape[1] / factor), round(img.shape[0] / factor)), interpolation=cv2.INTER_AREA)
    ok, enc = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 95])
    segments, i = [], 2
    while i + 4 <= len(data) and data[i] == 0xFF and data[i + 1] != 0xDA:
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if data[i + 1] == 0xE1 and (xmp or data[i + 4:i + 10] == b"Exif\x00\x00"):
            segments.append(data[i:i + 2 + length])
        i += 2 + length
    Path(dst).write_bytes(b"\xff\xd8" + b"".join(segments) + enc.tobytes()[2:])
    return Path(dst)


def replace_exif_text(path, old: str, new: str) -> None:
    """Replace every ``old`` in the EXIF segment by ``new`` of the same length (e.g. the camera model)."""
    if len(old) != len(new):
        raise ValueError("same length only: the EXIF offsets stay valid")
    data = Path(path).read_bytes()
    start, end = _app1(data, b"Exif\x00\x00")
    seg = data[start:end]
    if old.encode() not in seg:
        raise ValueError(f"{path}: {old!r} not in its EXIF")
    Path(path).write_bytes(data[:start] + seg.replace(old.encode(), new.encode()) + data[end:])


def copy_frames(src_folder, names, dst_folder) -> list[Path]:
    """Copies of the JPEGs ``names`` (stems) of ``src_folder`` in ``dst_folder`` (never edit the shared data)."""
    dst = Path(dst_folder)
    dst.mkdir(parents=True, exist_ok=True)
    return [Path(shutil.copy(Path(src_folder) / f"{n}.JPG", dst / f"{n}.JPG")) for n in names]


def set_exif_tags(path, tags: dict, *, interop: dict | None = None, drop=()) -> None:
    """Set the EXIF sub-IFD's ``tags`` ``{tag: value}`` (added when absent, e.g. 0xA405 FocalLengthIn35mmFilm), the
    Interoperability IFD's ``interop`` entries, and drop the EXIF sub-IFD's ``drop`` tags (e.g. 0x927C, the maker
    note), re-serialising the EXIF APP1 segment with PIL (what a tool that rewrites the EXIF leaves)."""
    from PIL import Image
    data = Path(path).read_bytes()
    start, end = _app1(data, b"Exif\x00\x00")
    ex = Image.Exif()
    ex.load(data[start:end])
    ifd = ex.get_ifd(0x8769)
    ifd.update(tags)
    for tag in drop:
        ifd.pop(tag, None)
    if interop:
        ex.get_ifd(0xA005).update(interop)
    body = ex.tobytes()
    body = body if body.startswith(b"Exif") else b"Exif\x00\x00" + body
    head = start - 4
    Path(path).write_bytes(data[:head] + b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body + data[end:])
