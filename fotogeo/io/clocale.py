"""The C library's case rules while GDAL starts: a Turkish or Azeri locale changes what ``strcasecmp`` says.

Under ``LC_CTYPE`` tr_TR or az_AZ, glibc's ``strcasecmp`` tells ``i`` from ``I`` (their upper case of ``i`` is
``İ``, of ``I`` lower case ``ı``), and GDAL compares names case-insensitively with it. The GDAL 3.12 bundled with
pyogrio checks at start-up that its list of known configuration options is sorted by that compare and printed 57
"ERROR 1: apszKnownConfigOptions[] isn't correctly sorted" lines on every run that read or wrote a vector layer
(QGIS sets the process locale from the user's language). :func:`c_case_rules` switches the calling thread to
``C.UTF-8`` case rules (glibc ``newlocale``/``uselocale``: thread-local, other threads and Python keep theirs),
which :func:`import_pyogrio` uses around the import that starts pyogrio's GDAL and the GeoPackage writer and the
table reader around their pyogrio calls (pyogrio also warned "driver GPKG does not support creation option VERSION").
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import sys

_LC_CTYPE_MASK = 1  # glibc: 1 << LC_CTYPE, LC_CTYPE == 0


@functools.lru_cache(maxsize=1)
def _libc():
    """glibc through ctypes, or None: the masks below are glibc's, and elsewhere (Windows has no C library to find,
    macOS numbers the categories otherwise) the case rules GDAL meets are not the Turkish ones."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = _own_libc()
        libc.newlocale.restype = libc.uselocale.restype = ctypes.c_void_p
        libc.newlocale.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_void_p]
        libc.uselocale.argtypes = [ctypes.c_void_p]
        libc.freelocale.argtypes = [ctypes.c_void_p]
        libc.strcasecmp.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
        return libc
    except (OSError, AttributeError, TypeError):  # no C library or no POSIX 2008 locales: nothing to switch
        return None


def _own_libc():
    """The C library the process runs on: its own symbols (``dlopen(NULL)``), which hold the C library's; only where
    they lack ``newlocale`` (a static build) the library ``ctypes.util.find_library`` names, whose search runs
    ``ldconfig -p`` in a child process (every command line run starts here: docs/benchmarks/products.md)."""
    libc = ctypes.CDLL(None)
    if hasattr(libc, "newlocale"):
        return libc
    from ctypes.util import find_library
    return ctypes.CDLL(find_library("c") or None)


@contextlib.contextmanager
def c_case_rules():
    """Within the block, the calling thread compares and converts case as in ``C.UTF-8`` (``C`` where that
    locale is missing); elsewhere, and where the C library has no ``uselocale``, nothing changes."""
    libc = _libc()
    loc = libc and (libc.newlocale(_LC_CTYPE_MASK, b"C.UTF-8", None) or libc.newlocale(_LC_CTYPE_MASK, b"C", None))
    if not loc:
        yield
        return
    old = libc.uselocale(loc)
    try:
        yield
    finally:
        libc.uselocale(old)
        libc.freelocale(loc)


def c_case_rules_for_process() -> bool:
    """In a process fotogeo runs itself (the command line, the QGIS plugin's worker): when the inherited ``LC_CTYPE``
    tells ``i`` from ``I`` (tr_TR, az_AZ), use ``C.UTF-8``'s for the whole process, its threads included; else
    nothing. There GDAL 3.10 warned "driver GTiff does not support creation option COMPRESS" (and TILED,
    BLOCKXSIZE, PREDICTOR, BIGTIFF, NUM_THREADS) on every GeoTIFF written, though it applied them. Python's own
    encodings are fixed at start-up and unchanged. Returns whether the process was switched."""
    import locale
    libc = _libc()
    if libc is None or libc.strcasecmp(b"I", b"i") == 0:
        return False
    for name in ("C.UTF-8", "C"):
        try:
            locale.setlocale(locale.LC_CTYPE, name)
            return True
        except locale.Error:
            continue
    return False


def import_pyogrio():
    """Import pyogrio (and so start its GDAL) under C case rules; geopandas then uses that module."""
    with c_case_rules():
        import pyogrio
    return pyogrio
