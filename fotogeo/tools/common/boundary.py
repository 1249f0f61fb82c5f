"""The tool boundary: options checked before any file is read, library exceptions turned into
:class:`~fotogeo.errors.FotogeoError` s naming the file and the fix.

Every public tool function (``fotogeo/tools/<tool>.py``) is decorated with :func:`tool`::

    @tool("ORIENT", "GCP", rasters={"image": None, "dem": None}, outputs=OUTPUTS + ("points",))
    def orient(image, gcps, *, model="auto", ...): ...

Before the tool runs, each keyword argument declared in the tool's option tables
(:mod:`fotogeo.options`) is checked against its kind, range and choices — the same check for
the command line, QGIS and the Python API — and each raster argument's header is looked at
(a complex-valued raster is refused; a nodata option must fit the raster's data type).

While it runs, what a library raises becomes one :class:`FotogeoError` with a one-line
message (:func:`fotogeo.errors.one_line`: no WKT, no long values, no traceback):

=======================================  ==========================================================
raised                                   becomes
=======================================  ==========================================================
``OSError`` ENOSPC, "disk is full"       :class:`OutputError` naming the *final* output path(s)
                                         (never the hidden temporary), the folder and the fix
``OSError`` EACCES / EPERM / EROFS       :class:`OutputError` (an output) or :class:`InputError`
``IsADirectoryError``, ENOENT            the argument it concerns is a folder / does not exist
rasterio / GDAL errors                   :class:`RasterError` naming the raster
pyogrio, pandas parser errors            :class:`VectorError` naming the table
XML, YAML, Unicode decoding errors       :class:`InputError` naming the file
``numpy.linalg.LinAlgError``,            :class:`ModelError` (singular fit: degenerate points)
``FloatingPointError``
``MemoryError``                          :class:`InputError` (the inputs or the output grid are
                                         too large for the memory)
pyproj errors (``CRSError``)             :class:`InputError` naming the CRS option given and the input
=======================================  ==========================================================

A :class:`FotogeoError` raised by the tool itself passes through, reduced to one line and
with temporary paths replaced by the final ones. Other exceptions (programming errors)
propagate unchanged, so that they are seen and fixed rather than hidden.
"""
from __future__ import annotations

import dataclasses
import errno
import functools
import inspect
import re
from pathlib import Path

from ...errors import (Cancelled, FotogeoError, InputError, ModelError, OutputError, RasterError, VectorError,
                      one_line)
from ...io.raster import is_virtual_path

#: argument names of the tools that name files written; any other path argument is read
OUTPUTS = ("output", "vectors", "report", "plot", "rpc", "gcp_tiff", "rectify", "table", "markdown", "folder")
_NO_SPACE = ("no space left on device", "disk is full", "disk full")
_DENIED = ("permission denied", "read-only file system", "operation not permitted")


def tool(*tables, rasters: dict | None = None, outputs: tuple = OUTPUTS):
    """Decorate a tool function: check its options, then translate library exceptions.

    ``tables`` are the tool's option tables (or their names in :mod:`fotogeo.options`); ``rasters`` maps each raster argument to the
    name of its nodata option (or None); ``outputs`` names the arguments that are written.
    """
    from ... import options
    tables = tuple(getattr(options, t) if isinstance(t, str) else t for t in tables)

    def decorate(func):
        signature = inspect.signature(func)

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            try:
                bound = signature.bind(*args, **kwargs)
            except TypeError:
                return func(*args, **kwargs)  # Python reports the wrong call itself
            values = _argument_values(bound)
            check_options(values, tables)
            check_rasters(values, rasters or {})
            call = _Call(func.__name__, values, outputs)
            try:
                return func(*args, **kwargs)
            except Cancelled:
                raise
            except FotogeoError as exc:
                error = translate_own(exc, call)
                if error is None:
                    raise
                raise error from exc.__cause__
            except (Exception, MemoryError) as exc:  # noqa: BLE001 - filtered by translate()
                error = translate(exc, call)
                if error is None:
                    raise
                raise error from exc
        wrapper.__wrapped_tool__ = func
        return wrapper
    return decorate


def _argument_values(bound) -> dict:
    """Argument name → value, with ``**kwargs`` and an ``options`` dataclass spread out."""
    values = {}
    for name, value in bound.arguments.items():
        kind = bound.signature.parameters[name].kind
        if kind is inspect.Parameter.VAR_KEYWORD:
            values.update(value)
        elif name == "options" and dataclasses.is_dataclass(value) and not isinstance(value, type):
            values.update(dataclasses.asdict(value))
        else:
            values[name] = value
    return values


def check_options(values: dict, tables) -> None:
    """Check each value named in ``tables`` (the first table declaring a name wins), then that no option is given
    without the option it needs (:func:`~fotogeo.options.table.check_needs`)."""
    from ...options.table import check_needs
    declared = {}
    for table in tables:
        for name, option in table.items():
            declared.setdefault(name, option)
    for name, value in values.items():
        if name in declared:
            declared[name].check(value)
    check_needs(values, declared.values())


def check_nodata(value, dtype: str, what: str) -> None:
    """Refuse a nodata ``value`` that the data type ``dtype`` cannot hold.

    >>> check_nodata(300, "uint8", "target_nodata")
    Traceback (most recent call last):
    fotogeo.errors.InputError: target_nodata 300 cannot be stored in the raster's uint8 pixels (0..255); give a value in that range or none
    """
    import numpy as np
    kind = np.dtype(dtype).kind
    if value is None or kind not in "iuf":
        return
    info = np.iinfo(dtype) if kind in "iu" else np.finfo(dtype)
    if not info.min <= value <= info.max:
        raise InputError(f"{what} {value!r} cannot be stored in the raster's {dtype} pixels "
                         f"({info.min:g}..{info.max:g}); give a value in that range or none")
    if kind in "iu" and float(value) != int(value):
        raise InputError(f"{what} {value!r} is not a whole number; the raster's {dtype} pixels hold "
                         f"whole numbers {info.min}..{info.max}")


def check_rasters(values: dict, rasters: dict) -> None:
    """Look at each raster argument's header: refuse complex pixels and a nodata it cannot hold.

    Arguments that are missing, not paths or not readable are left to the tool, which says so.
    """
    for name, nodata_option in rasters.items():
        path = values.get(name)
        if not isinstance(path, (str, Path)) or not (is_virtual_path(path) or Path(path).is_file()):
            continue
        dtype = _raster_dtype(path)
        if dtype is None:
            continue
        if dtype.startswith("complex"):
            raise InputError(f"{name} {str(path)!r} has complex ({dtype}) pixels, which fotogeo cannot match or "
                             f"resample; convert it to real values first (e.g. gdal_translate -ot Float32, or its "
                             f"amplitude)")
        if nodata_option:
            check_nodata(values.get(nodata_option), dtype, nodata_option)


def _raster_dtype(path) -> str | None:
    try:
        from ...io.raster import ropen
        with ropen(path) as ds:
            return ds.dtypes[0]
    except Exception:  # noqa: BLE001 - the tool reports unreadable rasters itself
        return None


def _may_be_path(p: Path) -> bool:
    """An existing file or a name with an extension; text no file system takes (a WKT CRS longer than a
    file name may be: ``OSError`` "File name too long") is not a path."""
    try:
        return p.exists() or bool(p.suffix)
    except OSError:
        return False


class _Call:
    """One tool call: its name and the files it reads and writes, for error messages."""

    def __init__(self, name: str, values: dict, outputs: tuple):
        self.name = name
        paths = {k: Path(v) for k, v in values.items() if isinstance(v, (str, Path)) and str(v)}
        self.outputs = {k: p for k, p in paths.items() if k in outputs}
        self.inputs = {k: p for k, p in paths.items() if k not in outputs and _may_be_path(p)}
        #: the CRS option given (name, value), named when a CRS cannot be used
        self.crs = next(((k, values[k]) for k in ("crs", "dst_crs", "gcp_crs")
                         if values.get(k) not in (None, "", "auto")), None)

    def final_paths(self, text: str) -> str:
        """``text`` with the hidden temporary files (``.OUT.xxxx.part.tif``) named by their final paths."""
        for final in self.outputs.values():
            stem = re.escape(final.stem if final.suffix else final.name)
            pattern = (r"(?:[^\s'\"]*[/\\])?\.+%s\.[^\s'\"/\\]*?\.(?:part|probe|bak)(\.[A-Za-z0-9]+)?"
                       r"(?:\.part(?:\.[A-Za-z0-9]+)?)*" % stem)
            text = re.sub(pattern, lambda m: str(final.with_suffix(m.group(1)) if m.group(1) and final.suffix
                                                 else final), text)
        return text

    def role_of(self, path) -> tuple[str, bool]:
        """``(argument name, is an output)`` of ``path`` (a temporary counts as its output)."""
        if path is None:
            return "", False
        p = Path(self.final_paths(str(path)))
        for role, q in self.outputs.items():
            if p == q or (p.parent == q and role == "folder") or p.name == q.name:
                return role, True
        for role, q in self.inputs.items():
            if p == q or p.name == q.name:
                return role, False
        return "", False

    def file_in(self, exc: BaseException):
        """The file an exception is about: its ``filename``, else a path argument its message names."""
        name = getattr(exc, "filename", None)
        if name:
            return self.final_paths(str(name))
        text = self.final_paths(str(exc))
        for p in [*self.outputs.values(), *self.inputs.values()]:
            if str(p) in text or (p.name and p.name in text):
                return str(p)
        return None

    def out_list(self) -> str:
        return ", ".join(repr(str(p)) for p in self.outputs.values()) or "the outputs"


def _library(exc: BaseException) -> str:
    """The top-level module of the library that defined ``exc``'s class (or a base of it)."""
    for cls in type(exc).__mro__:
        module = cls.__module__.split(".")[0]
        if module not in ("builtins", "fotogeo"):
            return module
    return "builtins"


#: free space (bytes) under which a failed write is reported as a full disk: the libraries
#: rarely pass ENOSPC on (libtiff prints it, GDAL says "Write failed", SQLite "no such table")
LOW_SPACE_BYTES = 64 * 2 ** 20


def _free_bytes(folder: Path) -> int | None:
    import shutil
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None


def _full_disk(call: _Call, file) -> tuple[str, int] | None:
    """``(folder, free bytes)`` of the output folder with less than :data:`LOW_SPACE_BYTES` free."""
    folders = [Path(file).parent] if file else []
    folders += [p.parent if p.suffix or not p.is_dir() else p for p in call.outputs.values()]
    for folder in folders:
        free = _free_bytes(folder.resolve())
        if free is not None and free < LOW_SPACE_BYTES:
            return str(folder), free
    return None


def _disk_full_error(call: _Call, file, is_output: bool, folder: str, free: int | None, text: str = ""):
    target = repr(file) if file and is_output else call.out_list()
    left = "" if free is None else f" ({free / 2 ** 20:.1f} MB left)"
    cause = f" ({one_line(text, limit=160)})" if text else ""
    return OutputError(one_line(f"disk full while writing {target}{cause}: free space on the disk of {folder!r}"
                                f"{left} or write the outputs to another disk; nothing was written"))


def _denied(exc: BaseException, text: str) -> bool:
    """Whether ``exc`` is a refused write or read (permissions, a read-only file system), whatever the free space:
    a read-only disk that is also small is not a full one."""
    low = text.lower()
    return (_os_errno(exc) in (errno.EACCES, errno.EPERM, errno.EROFS) or any(s in low for s in _DENIED)
            or "is not writable" in low)


def _os_errno(exc: BaseException) -> int | None:
    """The operating system's error number of ``exc``; None for GDAL's errors, whose ``errno`` is GDAL's own error
    class (``CPLE_AppDefined`` is 1, which as an OS number is EPERM: a GDAL error read as "permission denied")."""
    return getattr(exc, "errno", None) if isinstance(exc, OSError) else None


def translate_own(exc: FotogeoError, call: _Call) -> FotogeoError | None:
    """``exc`` in one line with final paths, whole however long (a refusal cut would lose what it names or its
    fix); a failed write on a full disk says so. None: unchanged."""
    text = one_line(call.final_paths(str(exc)), limit=None)
    about_space = text.lower().startswith("disk full") or "free space" in text.lower()
    denied = _denied(exc, text)
    if isinstance(exc, OSError) and not isinstance(exc, (InputError, ModelError)) and not about_space and not denied:
        file = call.file_in(exc)
        role, is_output = call.role_of(file)
        low = _full_disk(call, file) if is_output or "writ" in text.lower() else None
        if low:
            return _disk_full_error(call, file, is_output, *low, text)
    if text == str(exc):
        return None
    return type(exc)(text, option=getattr(exc, "option", None))


def translate(exc: BaseException, call: _Call) -> FotogeoError | None:
    """The :class:`FotogeoError` that ``exc`` (raised inside ``call``) becomes, or None."""
    text = one_line(call.final_paths(str(exc)) or type(exc).__name__, limit=300)
    low = text.lower()
    file = call.file_in(exc)
    role, is_output = call.role_of(file)
    about = f"{role} {file!r}" if role else (repr(file) if file else "")
    code = _os_errno(exc)
    lib = _library(exc)
    writing = is_output or "writ" in low
    if code == errno.ENOSPC or any(s in low for s in _NO_SPACE):
        folder = Path(file).parent if file else next(iter(call.outputs.values()), Path("x")).parent
        return _disk_full_error(call, file, is_output, str(folder), _free_bytes(folder))
    denied = _denied(exc, text)
    full = (_full_disk(call, file) if writing and not denied and (lib == "rasterio" or isinstance(exc, OSError))
            else None)
    if full:
        return _disk_full_error(call, file, is_output, *full, text)
    if denied:
        if is_output or not file:
            return OutputError(one_line(f"cannot write {about or call.out_list()}: permission denied; choose a "
                                        f"folder you can write to"))
        return InputError(one_line(f"cannot read {about}: permission denied; make it readable or copy it"))
    if isinstance(exc, IsADirectoryError) or code == errno.EISDIR or "is a directory" in low:
        what = about or call.out_list()
        return (OutputError if is_output else InputError)(one_line(f"{what} is a folder; give a file path"))
    if isinstance(exc, FileNotFoundError) or code == errno.ENOENT:
        what = about or repr(file)
        fix = "its folder must exist" if is_output else "check the path"
        return (OutputError if is_output else InputError)(one_line(f"{what} does not exist ({text}); {fix}"))
    return _translate_library(exc, call, text, about, writing, lib)


def _translate_library(exc, call: _Call, text: str, about: str, writing: bool, lib: str):
    """The error of a library exception that is not about disk space, permissions or paths."""
    name = type(exc).__name__
    if lib == "rasterio" or name.startswith("CPLE_"):
        if writing:
            return RasterError(one_line(f"GDAL could not write {about or call.out_list()}: {text}; check the folder "
                                        f"and the free space"))
        return RasterError(one_line(f"GDAL could not read {about or 'a raster of ' + call.name}: {text}; check that "
                                    f"it is a complete raster GDAL can read (gdalinfo)"))
    if lib in ("pyogrio", "fiona", "shapely", "geopandas"):
        verb = "write" if writing else "read"
        return VectorError(one_line(f"could not {verb} the vector layer {about or 'of ' + call.name}: {text}"))
    if lib == "pandas":
        return VectorError(one_line(f"could not read the table {about}: {text}; it must be a CSV with a header "
                                    f"line and one point per line"))
    if lib in ("xml", "yaml") or isinstance(exc, (UnicodeError, SyntaxError)):
        return InputError(one_line(f"{about or 'an input file'} cannot be parsed: {text}; check its format"))
    if name == "LinAlgError" or isinstance(exc, FloatingPointError):
        return ModelError(one_line(f"{call.name}: the fit is singular ({text}): the points are too few, "
                                   f"collinear or coincident; add well-spread points or choose a simpler model"))
    if isinstance(exc, MemoryError):
        return InputError(one_line(f"{call.name}: not enough memory ({text}); use a coarser output resolution, "
                                   f"smaller inputs or a machine with more memory"))
    if lib == "pyproj" and name == "CRSError":
        given, option = (f"{call.crs[0]} {str(call.crs[1])!r} or ", call.crs[0]) if call.crs else ("", None)
        return InputError(one_line(f"{call.name}: {given}the CRS of {about or 'the inputs'} cannot be used "
                                   f"({text}); give a CRS pyproj knows (EPSG code, WKT or PROJ string)"),
                          option=option)
    if lib == "pyproj":  # a transformation or PROJ's data, not the CRS given
        return InputError(one_line(f"{call.name}: PROJ could not transform the coordinates ({text}); check the "
                                   f"CRSs of the inputs and PROJ's data (pyproj.datadir, PROJ_DATA)"))
    if isinstance(exc, OSError):
        kind = OutputError if writing else InputError
        return kind(one_line(f"{call.name}: {about or 'a file'}: {text}"))
    return None
