"""What ``fotogeo dsm`` reads besides the orientation (which :mod:`fotogeo.tools.ortho.inputs` reads, as for
``ortho``): triangulate's output folder, the pairs file, the bounds, and the images' grey values and colours."""
from __future__ import annotations

import os
import re
import threading
import warnings
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ...errors import FotogeoWarning, InputError
from ...io.raster import gdal_env, open_raster, ropen
from ...stereo.texture import noise_sigma
from ..common.checks import distinct_files
from .plan import footprint


def check_crs(crs) -> None:
    """Refuse a ``crs`` pyproj cannot read before any input is opened, as a bad value of the option ``crs`` (the
    command line's usage error, as a bad ``--bounds``); "auto" and None choose it."""
    from ...crs import parse_crs
    if crs is not None and str(crs).strip().lower() != "auto":
        try:
            parse_crs(crs, "crs")
        except InputError as e:
            raise InputError(str(e), option="crs") from None


def orientation_inputs(orientation, camera, eo) -> list:
    """The orientation's files as :func:`orientation_files` would take them, without checking them (the outputs'
    checks, before any refusal of the inputs, must not write over them)."""
    if orientation is None:
        return [camera, eo]
    from ..triangulate.outputs import CAMERA_FILE, FILES
    return [camera if camera is not None else Path(orientation) / CAMERA_FILE, Path(orientation) / FILES[0]]


def orientation_files(orientation, camera, eo) -> tuple:
    """``(camera, eo)``: from triangulate's output folder ``orientation`` (its exterior_orientation.txt and
    camera.yaml; ``camera``, when given, instead of the folder's), or as given."""
    if orientation is None:
        return camera, eo
    from ..triangulate.outputs import CAMERA_FILE, FILES
    folder = Path(orientation)
    if eo is not None:
        raise InputError("give either orientation (triangulate's output folder) or eo, not both",
                         option="orientation", also=("eo",))
    eo_path = folder / FILES[0]
    if not folder.is_dir() or not eo_path.is_file():
        raise InputError(f"orientation {str(orientation)!r} is not an output folder of fotogeo triangulate (no "
                         f"{FILES[0]} in it)", option="orientation")
    cam = folder / CAMERA_FILE
    if camera is None and not cam.is_file():
        raise InputError(f"camera needed: orientation {str(orientation)!r} holds no {CAMERA_FILE} (an older "
                         f"fotogeo's triangulate wrote it only when self-calibrating); give the camera's file",
                         option="camera", also=("orientation",))
    camera = camera if camera is not None else cam
    return camera, eo_path


#: the longest side of the decimated read that compares two images' pixels (:func:`distinct_images`)
COMPARE_SIDE = 64


def distinct_images(ims, heights) -> None:
    """Refuse an image given twice (:class:`~fotogeo.tools.ortho.inputs.OrthoImage` list ``ims``): one file by two
    paths, two images of one name (their file stem: the pairs, ``--pairs`` and the report know an image by it), or
    a copy — the same size, the same orientation (their outlines on the planes ``heights`` within 1 mm) and the
    same pixels (a read decimated to ``COMPARE_SIDE`` pixels a side, only of images whose size and outlines
    agree). A copy adds no view: each cell it shares with its original would count that pair twice and look
    checked by a second one."""
    distinct_files([im.path for im in ims], [im.name for im in ims])
    outlines = [np.concatenate([footprint(im, z) for z in heights]) for im in ims]
    for a, i in enumerate(ims):
        for b in range(a + 1, len(ims)):
            j = ims[b]
            if (i.width, i.height) == (j.width, j.height) and outlines[a].shape == outlines[b].shape \
                    and np.allclose(outlines[a], outlines[b], rtol=0.0, atol=1e-3) \
                    and np.array_equal(_decimated(i), _decimated(j)):
                raise InputError(f"images: {i.path!r} and {j.path!r} hold the same pixels and orientation (a copy): "
                                 f"it adds no view; give each image once")


def _decimated(im) -> np.ndarray:
    """All bands of image ``im`` read (nearest) at most ``COMPARE_SIDE`` pixels a side."""
    k = max(1, -(-max(im.width, im.height) // COMPARE_SIDE))
    with gdal_env(), ropen(im.path) as ds:
        return ds.read(out_shape=(ds.count, -(-im.height // k), -(-im.width // k)))


def read_pairs(pairs, names) -> list | None:
    """Index pairs from ``pairs``: a text file of two image names per line (``#`` comments), or a sequence of
    name pairs; None for automatic choice. A line that does not name two of the images is refused, naming the line
    and the name not among them. Messages call the option ``pairs`` (the caller's word for it replaces it,
    :func:`fotogeo.errors.in_callers_words`)."""
    if pairs is None:
        return None
    given = f"pairs {str(pairs)!r}"
    if isinstance(pairs, (str, Path)):
        path = Path(pairs)
        if not path.is_file():
            raise InputError(f"{given} does not exist", option="pairs")
        rows = [(k + 1, _pair_line(line)) for k, line in enumerate(path.read_text(encoding="utf-8").splitlines())]
        rows = [(k, r) for k, r in rows if r]
    else:
        rows = [(k + 1, list(p)) for k, p in enumerate(pairs)]
    index = {n: i for i, n in enumerate(names)}
    among = f"{', '.join(names[:6])}{' ...' if len(names) > 6 else ''}"
    out = []
    for line, r in rows:
        r = [Path(str(x)).stem for x in r]
        unknown = [x for x in r if x not in index]
        if len(r) == 2 and unknown:
            raise InputError(f"{given} line {line}: {unknown[0]!r} is not among the images ({among}); give their "
                             f"file names without folder and extension", option="pairs")
        if len(r) != 2 or r[0] == r[1]:
            spaced = next((n for n in names if " " in n), None)
            quote = (f" (a name with spaces in quotes or the two names separated by a tab: \"{spaced}\" \"...\")"
                     if spaced and len(r) > 2 else "")
            raise InputError(f"{given} line {line}: expected two different image names among {among}{quote}; got "
                             f"{' '.join(r)!r}", option="pairs")
        out.append(tuple(sorted((index[r[0]], index[r[1]]))))
    if not out:
        raise InputError(f"{given} names no pair", option="pairs")
    return sorted(set(out))


def _pair_line(line: str) -> list:
    """The names on one line of a pairs file: after ``#`` a comment; two names separated by a tab, or by commas or
    spaces, a name with spaces or commas in double or single quotes (``"frame one" "frame two"``)."""
    if re.search(r"(^|[\s,])[\"']", line):  # a quoted name (an apostrophe inside a name is no quote)
        import shlex
        lex = shlex.shlex(line, posix=True)
        lex.whitespace, lex.whitespace_split, lex.commenters = lex.whitespace + ",", True, "#"
        try:
            return list(lex)
        except ValueError:  # an unpaired quote: a name with an apostrophe
            pass
    line = line.split("#")[0]
    if "\t" in line.strip():
        return [x.strip() for x in line.split("\t") if x.strip()]
    return line.replace(",", " ").split()


def parse_bounds(bounds) -> tuple | None:
    """``(xmin, ymin, xmax, ymax)`` from 'xmin,ymin,xmax,ymax' (or a sequence), None when not given."""
    if bounds is None:
        return None
    try:
        v = [float(x) for x in (bounds.replace(" ", ",").split(",") if isinstance(bounds, str) else bounds) if x != ""]
    except ValueError:
        v = []
    if len(v) != 4 or not (v[2] > v[0] and v[3] > v[1]) or not np.isfinite(v).all():
        raise InputError(f"bounds {bounds!r}: give 'xmin,ymin,xmax,ymax' in the output CRS with xmax > xmin and "
                         f"ymax > ymin", option="bounds")
    return tuple(v)


def _to_uint8(a) -> np.ndarray:
    if a.dtype == np.uint8:
        return a
    v = a[a > 0] if (a > 0).any() else a.ravel()
    lo, hi = np.percentile(v, [0.5, 99.5])
    return np.clip((a.astype(np.float32) - lo) * 255.0 / max(float(hi - lo), 1e-6), 0, 255).astype(np.uint8)


def read_image(path) -> tuple:
    """``(grey float32 (h, w), colours [3 x uint8 (h, w)])`` of an image, whole: grey and colours as
    :class:`SourceImage` gives them (its first three bands weighted, or its one band; those bands stretched to 8
    bits, or the grey three times)."""
    src = SourceImage(path)
    data = src.read(0, 0, src.width, src.height)
    grey = np.tensordot(src.weights, data.astype(np.float32), axes=1)
    if len(data) >= 3:
        cols = [_to_uint8(b) for b in data[:3]]
    else:
        cols = [_to_uint8(data[0])] * 3
    return grey, cols


#: the longest side of the decimated read that gives an image's colour stretch
STRETCH_SIDE = 1024
#: :meth:`SourceImage.noise` is measured on this many bands of this many full-resolution rows
NOISE_BANDS, NOISE_ROWS = 8, 32
#: an untiled source image is decoded whole once when its bands take at most this many bytes (:class:`SourceImage`)
CACHE_IMAGE_BYTES = 256 * 2 ** 20
#: the decoded images this process keeps at most (bytes; the least recently used dropped first): two of the largest
#: cached images, a pair, always fit
CACHE_BYTES = 2 * CACHE_IMAGE_BYTES


class _Decoded:
    """The process's decoded untiled images (:class:`SourceImage`), keyed by path, modification time, size and
    bands; least recently used dropped beyond ``CACHE_BYTES``. Module state, never an instance's: a
    :class:`SourceImage` pickled into a Dask task carries its path, and each worker process decodes for itself."""

    def __init__(self):
        self.images, self.lock = OrderedDict(), threading.Lock()

    def get(self, key, decode) -> np.ndarray:
        with self.lock:  # one decode per image even when a worker's threads ask at once
            if key in self.images:
                self.images.move_to_end(key)
                return self.images[key]
            a = decode()
            self.images[key] = a
            while sum(x.nbytes for x in self.images.values()) > CACHE_BYTES and len(self.images) > 1:
                self.images.popitem(last=False)
            return a

    def clear(self) -> None:
        with self.lock:
            self.images.clear()


DECODED = _Decoded()


def _bands(value, count: int, path: str) -> list:
    """The band numbers ``value`` of the ``bands`` option (``"4,3,2"``, an int, a sequence; None: the first
    three) checked against the image's ``count`` bands."""
    from ..register.match import band_numbers
    numbers = band_numbers(value, "bands")
    if numbers is None:
        return list(range(1, min(3, count) + 1))
    outside = [n for n in numbers if n > count]
    if outside:
        raise InputError(f"bands {','.join(map(str, numbers))}: image {path!r} has {count} band"
                         f"{'s' if count > 1 else ''} (1-{count}); give band numbers in that range", option="bands")
    return list(numbers)


def _stretches(data) -> list:
    """Each band's ``(low, high)`` colour stretch of :class:`SourceImage` (None: already 8 bits): the 0.5 and 99.5
    percentiles of its values above 0 (all of them when none is)."""
    out = []
    for b in data:
        if b.dtype == np.uint8:
            out.append(None)
            continue
        v = b[b > 0] if (b > 0).any() else b.ravel()
        out.append(tuple(float(x) for x in np.percentile(v, [0.5, 99.5])))
    return out


class SourceImage:
    """An image read window by window: grey values (its first three bands weighted by
    :func:`fotogeo.image.fusion.band_weights`, the PCA fusion's first component scaled to sum 1 without the bands
    that carry nothing — empty, constant or noise —, computed once from the decimated read; its one band) and
    colours (its first three bands, or the grey three times, stretched to 8 bits between the 0.5 and 99.5
    percentiles of the whole image, taken from a read decimated to at most ``STRETCH_SIDE`` pixels a side).

    **Memory and decoding.** A tiled image (a GeoTIFF with internal tiles) is read by windows: memory follows the
    window, never the image. An untiled one (JPEG, PNG, a GeoTIFF in strips: its blocks are whole rows) whose
    bands take at most ``CACHE_IMAGE_BYTES`` is decoded whole at its first full-resolution read and kept in the
    process (:class:`_Decoded`, at most ``CACHE_BYTES``): each window is then a slice of it, the same pixels a
    windowed read gives, without decoding the compressed rows above the window again for every strip. Reads
    averaged over blocks (``k > 1``) always go through GDAL, which may use the format's reduced decoding."""

    def __init__(self, path, bands=None):
        info = open_raster(path, "image")
        self.path, self.width, self.height = str(path), info.width, info.height
        self.bands = _bands(bands, info.count, self.path)
        self._stretch = self._noise = None
        self.key = self._cache_key(info)
        self.weights = self._weights(info.nodata)

    def _weights(self, nodata) -> np.ndarray:
        """The bands' grey weights (class docstring)."""
        if len(self.bands) == 1:
            return np.ones(1, np.float32)
        from ...image.fusion import band_weights
        data = self._overview()
        self._stretch = _stretches(data)  # the colours' stretch from the same read
        return band_weights(data, nodata=nodata, name=f"image {self.path!r}").astype(np.float32)

    def _overview(self) -> np.ndarray:
        """The whole image read decimated to at most ``STRETCH_SIDE`` pixels a side."""
        k = max(1, -(-max(self.width, self.height) // STRETCH_SIDE))
        return self.read(0, 0, self.width, self.height, k)

    def _cache_key(self, info):
        """The :data:`DECODED` key of an untiled local image small enough to decode whole, else None."""
        if isinstance(info.path, str):  # a GDAL virtual path or URL: windows, as GDAL fetches them
            return None
        size = self.width * self.height * len(self.bands) * np.dtype(info.dtype).itemsize
        with gdal_env(), ropen(self.path) as ds:
            untiled = all(b[1] >= self.width for b in ds.block_shapes)
        if not untiled or size > CACHE_IMAGE_BYTES:
            return None
        st = os.stat(self.path)
        return self.path, st.st_mtime_ns, st.st_size, tuple(self.bands)

    def _decode(self) -> np.ndarray:
        with gdal_env(), ropen(self.path) as ds:
            return ds.read(indexes=self.bands)

    def read(self, x0: int, y0: int, x1: int, y1: int, k: int = 1) -> np.ndarray:
        """Bands ``(b, rows, cols)`` of the pixels ``[x0, x1) x [y0, y1)``, averaged over ``k x k`` blocks when
        ``k > 1`` (``ceil(size / k)`` pixels); a copy the caller may change."""
        return self._window(x0, y0, x1, y1, k, copy=True)

    def _window(self, x0: int, y0: int, x1: int, y1: int, k: int, copy: bool) -> np.ndarray:
        """:meth:`read`; without ``copy`` a decoded image's window is a view of it, not to be changed."""
        from rasterio.enums import Resampling
        from rasterio.windows import Window
        if k == 1 and self.key is not None and 0 <= x0 < x1 <= self.width and 0 <= y0 < y1 <= self.height:
            a = DECODED.get(self.key, self._decode)[:, y0:y1, x0:x1]
            return a.copy() if copy else a
        w, h = x1 - x0, y1 - y0
        shape = (len(self.bands), -(-h // k), -(-w // k))
        with gdal_env(), ropen(self.path) as ds:
            return ds.read(indexes=self.bands, window=Window(x0, y0, w, h), out_shape=shape,
                           resampling=Resampling.average if k > 1 else Resampling.nearest)

    def grey(self, x0: int, y0: int, x1: int, y1: int, k: int = 1) -> np.ndarray:
        """Grey values ``(rows, cols)`` float32 of the window (class docstring; :meth:`read`'s arguments)."""
        return np.tensordot(self.weights, self._window(x0, y0, x1, y1, k, copy=False).astype(np.float32), axes=1)

    def noise(self) -> float:
        """The noise σ of the grey values (:func:`fotogeo.stereo.texture.noise_sigma`) over ``NOISE_BANDS`` bands
        of ``NOISE_ROWS`` full-resolution rows spread over the image (0: nodata), computed once."""
        if self._noise is None:
            starts = np.unique(np.linspace(0, max(0, self.height - NOISE_ROWS), NOISE_BANDS).round().astype(int))
            bands = [self.grey(0, int(r), self.width, min(self.height, int(r) + NOISE_ROWS)) for r in starts]
            self._noise = noise_sigma(bands, [g > 0 for g in bands])
        return self._noise

    def stretches(self) -> list:
        """Each band's ``(low, high)`` colour stretch (None: already 8 bits), computed once (class docstring)."""
        if self._stretch is None:
            self._stretch = _stretches(self._overview())
        return self._stretch

    def colours(self, x0: int, y0: int, x1: int, y1: int) -> list:
        """Three uint8 ``(rows, cols)`` colour bands of the window (class docstring)."""
        data = self.read(x0, y0, x1, y1)
        out = []
        for b, s in zip(data, self.stretches()):
            if s is None:
                out.append(b)
            else:
                lo, hi = s
                out.append(np.clip((b.astype(np.float32) - lo) * 255.0 / max(hi - lo, 1e-6), 0, 255).astype(np.uint8))
        return out if len(out) >= 3 else [out[0]] * 3


def centres_in_area_of_use(views, crs) -> None:
    """Warn when the cameras given in ``--crs`` lie outside its area of use: the orientation's X, Y are then most
    likely in another CRS (NGI's Lo25 positions read as EPSG:32735 fall at −144° E, outside the zone's 24–30° E, and
    the DSM came out at easting −55 km without a word). A warning, not a refusal: a flight may reach a little
    beyond its zone's edge."""
    from ...crs import area_of_use, outside_area_of_use, short_name, to_lonlat
    aou = area_of_use(crs)
    if aou is None:
        return
    centres = np.array([v.centre[:2] for v in views])
    out = outside_area_of_use(crs, centres)
    lon, lat = to_lonlat(crs, centres).T
    if out.any():
        k = int(np.argmax(out))
        warnings.warn(f"--crs {short_name(crs)}: camera {views[k].name!r} at ({views[k].centre[0]:.0f}, "
                      f"{views[k].centre[1]:.0f}) lies at {lon[k]:.2f}° E, {lat[k]:.2f}° N, outside the CRS's area of "
                      f"use ({aou.west:g}..{aou.east:g}° E, {aou.south:g}..{aou.north:g}° N): are the orientation's "
                      f"X, Y in another CRS? The DSM is placed where they say", FotogeoWarning, stacklevel=4)
