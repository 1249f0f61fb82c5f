"""Run one fotogeo tool for another program: ``python -m fotogeo.worker`` (the QGIS plugin's route).

Why a separate process: the QGIS programs (``qgis``, ``qgis_process``) load their own GDAL,
GEOS and PROJ before any plugin code runs; the pip wheels fotogeo needs (rasterio, pyogrio,
shapely, pyproj) bundle other versions of the same libraries, which then get displaced
inside QGIS's process (seen with Debian's QGIS 3.22: pyogrio "Could not correctly detect
GDAL data files installed by pyogrio wheel", shapely "WKB output dimension must be 2 or 3",
rasterio reporting GDAL 3.6.2). In a process of its own each wheel loads its own libraries.

Protocol (one request per process, JSON lines, UTF-8):

- stdin: one line ``{"tool": NAME, "args": [...], "kwargs": {...}, "cwd": FOLDER}`` (NAME from :data:`TOOLS`;
  FOLDER, optional, the caller's working folder, against which relative paths in args and kwargs resolve);
  afterwards a line ``cancel`` asks the tool to stop at its next progress report.
- stdout: any number of ``{"type": "progress", "fraction": f, "message": m}`` and
  ``{"type": "warning", "message": m}`` lines, then exactly one
  ``{"type": "result", "result": R}`` (exit status 0) or
  ``{"type": "error", "error": CLASS, "message": M, "cancelled": bool}`` (exit status 2,
  or 130 for a cancel, as the command line). ``R`` is the tool's return value made JSON
  (:func:`to_json`). Anything else the libraries print goes to stderr.
- SIGTERM cancels as well: the running tool gets :class:`~fotogeo.errors.Cancelled` at once, so
  its :class:`~fotogeo.io.raster.AtomicOutputs` delete what they had started writing.

``python -m fotogeo.worker --session`` keeps one process for many quick requests (the GCP picker's
refits, :func:`serve_session`): each stdin line ``{"id": N, "tool": NAME, "kwargs": {...}}`` (NAME
from :data:`TOOLS` or :data:`SESSION_TOOLS`) gets ``{"id": N, "type": "warning", "message": m}``
lines, then exactly one ``{"id": N, "type": "result", "result": R}`` or
``{"id": N, "type": "error", "error": CLASS, "message": ONE_LINE}``; no progress lines. An error
never ends the session; EOF or a line ``quit`` does.

``python -m fotogeo.worker --check`` prints one JSON object describing the environment
(:func:`check_environment`): package versions, the GDAL/GEOS/PROJ each wheel runs with, the
native libraries actually loaded, and a smoke test of the calls that fail when the
libraries are mixed up.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import sys
import threading
import warnings
from pathlib import Path

#: tool name -> (module, function)
TOOLS = {
    "register": ("fotogeo.tools.register.tool", "register"),
    "match_images": ("fotogeo.tools.register.match", "match_images"),
    "orient": ("fotogeo.tools.orient.tool", "orient"),
    "compare_models": ("fotogeo.tools.orient.compare", "compare_models"),
    "fuse_raster": ("fotogeo.tools.register.fuse", "fuse_raster"),
    "transfer_gcps": ("fotogeo.tools.points.transfer", "transfer_gcps"),
    "measure_targets": ("fotogeo.tools.points.targets", "measure_targets"),
    "points_to_layer": ("fotogeo.tools.points.layers", "points_to_layer"),
    "layer_to_points": ("fotogeo.tools.points.layers", "layer_to_points"),
    "run_demo": ("fotogeo.tools.demo.tool", "run_demo"),
    "rpc_bias": ("fotogeo.tools.orient.rpc_bias", "rpc_bias"),
    "register_batch": ("fotogeo.tools.register.batch", "register_batch"),
    "coregister": ("fotogeo.tools.coreg.tool", "coregister"),
    "triangulate": ("fotogeo.tools.triangulate", "triangulate"),
    "interior": ("fotogeo.tools.interior.tool", "interior"),
    "ortho": ("fotogeo.tools.ortho.tool", "ortho"),
    "mosaic": ("fotogeo.tools.ortho.mosaic", "mosaic"),
    "dsm": ("fotogeo.tools.dsm.tool", "dsm"),
    "propose_gcps": ("fotogeo.tools.gcp.propose", "propose_gcps"),
}
#: the GCP picker's quick functions, callable in a session only (JSON in, JSON out, milliseconds)
SESSION_TOOLS = {
    "fit_gcps": ("fotogeo.tools.gcp.fit", "fit_gcps"),
    "sample_heights": ("fotogeo.tools.gcp.fit", "sample_heights"),
    "preview_warp": ("fotogeo.tools.gcp.preview", "preview_warp"),
    "read_image_gcps": ("fotogeo.tools.gcp.files", "read_image_gcps"),
    "write_image_gcps": ("fotogeo.tools.gcp.files", "write_image_gcps"),
}
#: arrays larger than this are summarised (shape only) in results, not listed
MAX_ARRAY = 10_000
EXIT_ERROR, EXIT_CANCELLED = 2, 130


def to_json(value, depth: int = 0):
    """``value`` as plain JSON types: paths → str, numpy → Python numbers and lists, dataclasses → dicts,
    a CRS → its WKT, objects with ``to_dict()`` → that; arrays above :data:`MAX_ARRAY` elements → ``{"shape": [...]}``.

    >>> from pathlib import Path
    >>> to_json({"p": Path("/a/b.tif"), "t": (1, 2.5), "n": None})
    {'p': '/a/b.tif', 't': [1, 2.5], 'n': None}
    """
    if depth > 12:
        return repr(value)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        return {str(k): to_json(v, depth + 1) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [to_json(v, depth + 1) for v in value]
    if hasattr(value, "dtype") and hasattr(value, "tolist"):  # numpy scalar or array
        if getattr(value, "size", 1) > MAX_ARRAY:
            return {"shape": list(value.shape)}
        return to_json(value.tolist(), depth + 1)
    if callable(getattr(value, "to_wkt", None)) and callable(getattr(value, "to_epsg", None)):  # a CRS
        return value.to_wkt()  # whole, without the PROJ-string warning its to_dict() gives
    if callable(getattr(value, "to_dict", None)):
        return to_json(value.to_dict(), depth + 1)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: to_json(getattr(value, f.name), depth + 1) for f in dataclasses.fields(value)}
    return repr(value)


def _json_line(obj) -> str:
    """One protocol line of ``obj`` made JSON (:func:`to_json`); NaN and infinities become null (JSON has none)."""
    try:  # the common case, without a copy: to_json only for what json cannot write itself
        return json.dumps(obj, ensure_ascii=False, allow_nan=False, default=to_json) + "\n"
    except (ValueError, TypeError):
        obj = to_json(obj)

    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, list):
            return [clean(x) for x in v]
        return v
    return json.dumps(clean(obj), ensure_ascii=False) + "\n"


class _Channel:
    """The protocol's stdout (a private copy of fd 1; fd 1 itself then points at stderr)."""

    def __init__(self):
        sys.stdout.flush()
        self._out = os.fdopen(os.dup(1), "w", encoding="utf-8", buffering=1)
        os.dup2(2, 1)  # C libraries and print() can no longer corrupt the protocol
        sys.stdout = sys.stderr
        self._lock = threading.Lock()

    def send(self, **message):
        with self._lock:
            self._out.write(_json_line(message))
            self._out.flush()


class _Job:
    """Cancel state shared by the progress callback, the stdin reader and the SIGTERM handler."""

    def __init__(self, channel: _Channel):
        self.channel, self.cancelled, self.running, self.stage = channel, False, False, ""

    def progress(self, fraction: float, message: str = "") -> bool:
        self.stage = message or self.stage
        self.channel.send(type="progress", fraction=float(fraction), message=message)
        return not self.cancelled

    def on_sigterm(self, signum, frame):
        from .errors import Cancelled
        first = not self.cancelled
        self.cancelled = True
        if first and self.running:  # raise once, inside the tool: its `with AtomicOutputs()` cleans up
            raise Cancelled(f"cancelled by the user during: {self.stage or 'processing'}")

    def read_commands(self, stream):
        for line in stream:
            if line.strip() == "cancel":
                self.cancelled = True


def _warning_hook(channel: _Channel):
    from .errors import warning_line

    shown = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = warning_line(message, category)  # translated or silenced, as on the command line
        if text is not None and text not in shown:  # a repeated message once, as on the command line
            shown.add(text)
            channel.send(type="warning", message=text)
    return show


def run_request(request: dict, job: _Job):
    """Import the tool named in ``request`` and call it with a progress callback; return its JSON result."""
    import importlib
    name = request.get("tool")
    if name not in TOOLS:
        raise ValueError(f"unknown tool {name!r}; one of {', '.join(TOOLS)}")
    module, attr = TOOLS[name]
    func = getattr(importlib.import_module(module), attr)
    previous = os.getcwd()  # relative paths are the caller's (the worker starts in the plugin's folder)
    os.chdir(request.get("cwd") or previous)
    job.running = True
    try:
        result = func(*request.get("args", []), progress=job.progress, **request.get("kwargs", {}))
    finally:
        job.running = False
        os.chdir(previous)  # per request: a worker serving another request starts from its own folder again
    return to_json(result)


def serve(stdin=None) -> int:
    """Read one request from ``stdin``, run it, report on the protocol channel; the exit status."""
    stdin = stdin or sys.stdin
    channel = _Channel()
    job = _Job(channel)
    signal.signal(signal.SIGTERM, job.on_sigterm)
    warnings.showwarning = _warning_hook(channel)
    try:
        request = json.loads(stdin.readline() or "{}")
    except ValueError as e:
        channel.send(type="error", error="InputError", message=f"fotogeo.worker: bad request ({e})", cancelled=False)
        return EXIT_ERROR
    threading.Thread(target=job.read_commands, args=(stdin,), daemon=True).start()
    from .errors import Cancelled, FotogeoError
    try:
        result = run_request(request, job)
    except Cancelled as e:
        channel.send(type="error", error="Cancelled", message=str(e), cancelled=True)
        return EXIT_CANCELLED
    except FotogeoError as e:
        channel.send(type="error", error=type(e).__name__, message=str(e), option=e.option,
                     also=list(e.also), cancelled=False)
        return EXIT_ERROR
    except Exception as e:  # noqa: BLE001 - a bug or an unexpected library error: name it, keep the traceback
        import traceback
        traceback.print_exc()
        channel.send(type="error", error=type(e).__name__, message=f"{type(e).__name__}: {e}", cancelled=False,
                     traceback=traceback.format_exc())
        return EXIT_ERROR
    channel.send(type="result", result=result)
    return 0

def _session_function(name):
    """The function a session request names (:data:`TOOLS` or :data:`SESSION_TOOLS`)."""
    import importlib
    from .errors import InputError
    table = {**TOOLS, **SESSION_TOOLS}
    if name not in table:
        raise InputError(f"unknown tool {name!r}; one of {', '.join(table)}")
    module, attr = table[name]
    return getattr(importlib.import_module(module), attr)


def answer_request(request: dict, channel: _Channel) -> None:
    """Run one session request and send its warnings, then its one result or error line."""
    from .errors import FotogeoError, one_line
    rid = request.get("id")
    try:
        func = _session_function(request.get("tool"))
        kwargs = request.get("kwargs") or {}
        if not isinstance(kwargs, dict):
            raise TypeError(f"kwargs must be a JSON object, got {type(kwargs).__name__}")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = func(progress=None, **kwargs)  # made JSON as it is written (_json_line)
    except FotogeoError as e:
        channel.send(id=rid, type="error", error=type(e).__name__, message=one_line(e, limit=None), option=e.option,
                     also=list(e.also))
        return
    except Exception as e:  # noqa: BLE001 - a bug or an unexpected library error: name it, keep the session
        import traceback
        traceback.print_exc()
        channel.send(id=rid, type="error", error=type(e).__name__, message=one_line(f"{type(e).__name__}: {e}"))
        return
    from .errors import warning_line
    for text in dict.fromkeys(warning_line(w.message, w.category) for w in caught):
        if text is not None:
            channel.send(id=rid, type="warning", message=text)
    channel.send(id=rid, type="result", result=result)


def serve_session(stdin=None) -> int:
    """Answer request lines from ``stdin`` until EOF or ``quit`` (module docstring); exit status 0.

    SIGTERM ends the session at once (the quick tools write nothing that would need cleaning up).
    """
    stdin = stdin or sys.stdin
    channel = _Channel()
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(0))
    for line in stdin:
        text = line.strip()
        if text == "quit":
            break
        if not text:
            continue
        try:
            request = json.loads(text)
            if not isinstance(request, dict):
                raise ValueError("a request is a JSON object")
        except ValueError as e:
            channel.send(id=None, type="error", error="InputError", message=f"fotogeo.worker: bad request ({e})")
            continue
        answer_request(request, channel)
    return 0


#: import name -> the packages fotogeo's tools import
PACKAGES = ("numpy", "rasterio", "pyproj", "shapely", "geopandas", "pyogrio", "cv2")
#: native libraries whose copies must not be mixed: a wheel's own, never the system's
NATIVE = ("libgdal", "libgeos", "libproj")


def _loaded_native_libraries() -> list[str]:
    """Paths of the GDAL, GEOS and PROJ libraries mapped into this process (Linux /proc/self/maps)."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as f:
            paths = {line.split()[-1] for line in f if line.rstrip().endswith(".so") or ".so." in line}
    except OSError:
        return []
    return sorted(p for p in paths if os.path.basename(p).startswith(NATIVE))


def check_environment() -> dict:
    """What this Python can run: versions, each wheel's GDAL/GEOS/PROJ, loaded libraries, problems.

    ``ok`` is True when every package imports, the smoke test passes and no GDAL/GEOS/PROJ
    library is loaded from outside a wheel (e.g. the system's, through ``LD_LIBRARY_PATH``).
    """
    import importlib
    import platform
    import tempfile
    from . import __version__
    info = {"python": sys.executable, "python_version": platform.python_version(), "fotogeo": __version__,
            "fotogeo_path": os.path.dirname(os.path.abspath(__file__)), "packages": {}, "libraries": {},
            "problems": []}
    for name in PACKAGES:
        try:
            info["packages"][name] = getattr(importlib.import_module(name), "__version__", "?")
        except Exception as e:  # noqa: BLE001 - ImportError or a broken binary wheel
            info["packages"][name] = None
            info["problems"].append(f"{name} cannot be imported: {type(e).__name__}: {e}")
    libs = info["libraries"]
    for key, expr in (("GDAL (rasterio)", "rasterio.__gdal_version__"),
                      ("GDAL (pyogrio)", "pyogrio.__gdal_version_string__"),
                      ("GEOS (shapely)", "shapely.geos_version_string"), ("PROJ (pyproj)", "pyproj.proj_version_str")):
        module, attr = expr.split(".")
        if info["packages"].get(module):
            libs[key] = str(getattr(sys.modules[module], attr, "?"))
    if not info["problems"]:
        try:
            from .io.smoke import smoke_test
            with tempfile.TemporaryDirectory() as folder:
                smoke_test(folder)
        except Exception as e:  # noqa: BLE001
            info["problems"].append(f"smoke test failed: {type(e).__name__}: {e}")
    info["loaded"] = _loaded_native_libraries()
    foreign = [p for p in info["loaded"] if "site-packages" not in p and ".libs" not in p]
    if foreign:
        info["problems"].append("system copies of GDAL/GEOS/PROJ are loaded instead of the wheels' own: "
                                f"{', '.join(foreign)} (LD_LIBRARY_PATH={os.environ.get('LD_LIBRARY_PATH', '')!r}, "
                                f"LD_PRELOAD={os.environ.get('LD_PRELOAD', '')!r})")
    info["ok"] = not info["problems"]
    return info


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    from .io.clocale import c_case_rules_for_process
    c_case_rules_for_process()  # QGIS passes the user's locale; GDAL compares option names by it
    if argv[:1] == ["--check"]:
        print(json.dumps(check_environment(), indent=1))
        return 0
    if argv == ["--session"]:
        return serve_session()
    if argv:
        print("usage: python -m fotogeo.worker [--check | --session]  (JSON requests on stdin)", file=sys.stderr)
        return EXIT_ERROR
    return serve()


if __name__ == "__main__":
    sys.exit(main())
