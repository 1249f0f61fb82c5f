"""Where things are on each operating system QGIS runs on: QGIS's own Python, a venv's interpreter, the
default profile, the library variables a worker must not inherit, and the fix a user can apply.

Pure functions of the platform (``sys.platform``: ``linux``, ``win32``, ``darwin``) and of the facts they are
given (``executable``, ``prefix``, ``environ``, ``exists``), so that the Windows and macOS logic is tested
on Linux (tests/test_runtime_platforms.py). Standard library only.

Inside QGIS ``sys.executable`` is QGIS itself, not a Python:

- Windows (OSGeo4W or the standalone installer): ``<QGIS>\\bin\\qgis-bin.exe``; QGIS's Python is
  ``<QGIS>\\apps\\Python3x\\python.exe`` (``sys.prefix``); a venv's interpreter is ``Scripts\\python.exe``.
- macOS (the qgis.org package): ``QGIS.app/Contents/MacOS/QGIS``; QGIS's Python is
  ``QGIS.app/Contents/MacOS/bin/python3``; a venv's interpreter is ``bin/python``.
- Linux (distribution packages): ``/usr/bin/qgis``; QGIS's Python is the system ``/usr/bin/python3``.
"""
from __future__ import annotations

import os
import re
from pathlib import PurePath, PurePosixPath, PureWindowsPath


def is_windows(platform: str) -> bool:
    return platform.startswith("win")


def is_macos(platform: str) -> bool:
    return platform == "darwin"


def _path(platform: str):
    return PureWindowsPath if is_windows(platform) else PurePosixPath


def venv_python(folder, platform: str) -> PurePath:
    """The interpreter of the venv ``folder``: ``Scripts\\python.exe`` on Windows, ``bin/python`` elsewhere."""
    p = _path(platform)(str(folder))
    return p / "Scripts" / "python.exe" if is_windows(platform) else p / "bin" / "python"


def base_python_candidates(platform: str, executable: str, prefix: str, environ=None) -> list[str]:
    """QGIS's Python interpreters to make the venv with, best first (module docstring)."""
    P = _path(platform)
    environ = environ or {}
    exe, pre = P(executable), P(prefix)
    out = []
    if not is_windows(platform) and not is_macos(platform):
        out.append("/usr/bin/python3")  # the distribution's Python, which QGIS's packages are built for
    if exe.name.lower().startswith("python"):
        out.append(str(exe))  # run as a script by a Python, not inside QGIS
    if is_windows(platform):
        out.append(str(pre / "python.exe"))
        root = environ.get("OSGEO4W_ROOT") or str(exe.parent.parent)
        out += sorted((str(P(root) / "apps" / v / "python.exe") for v in ("Python312", "Python311", "Python39",
                                                                           "Python313", "Python310")))
        out.append(str(P(root) / "bin" / "python3.exe"))
    elif is_macos(platform):
        out.append(str(exe.parent / "bin" / "python3"))  # QGIS.app/Contents/MacOS/bin/python3
        out.append(str(pre / "bin" / "python3"))
    else:
        out.append(str(pre / "bin" / "python3"))
    seen = set()
    return [c for c in out if not (c in seen or seen.add(c))]


def base_python(platform: str, executable: str, prefix: str, environ=None, exists=os.path.exists,
                which=None) -> str | None:
    """The first of :func:`base_python_candidates` that exists (``which("python3")`` last on Linux/macOS)."""
    for c in base_python_candidates(platform, executable, prefix, environ):
        if exists(c):
            return c
    if which is not None and not is_windows(platform):
        return which("python3")
    return None


def default_profile(platform: str, home: str, environ=None) -> PurePath:
    """QGIS 3's default profile folder (QGIS 4 keeps the QGIS3 folder name)."""
    environ = environ or {}
    P = _path(platform)
    if is_windows(platform):
        appdata = environ.get("APPDATA") or str(P(home) / "AppData" / "Roaming")
        return P(appdata) / "QGIS" / "QGIS3" / "profiles" / "default"
    if is_macos(platform):
        return P(home) / "Library" / "Application Support" / "QGIS" / "QGIS3" / "profiles" / "default"
    return P(home) / ".local" / "share" / "QGIS" / "QGIS3" / "profiles" / "default"


#: variables of QGIS's process that would make the worker's wheels load or read QGIS's libraries and data
COMMON_DROPPED = ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "GDAL_DATA", "GDAL_DRIVER_PATH", "PROJ_LIB",
                  "PROJ_DATA", "GEOS_LIBRARY_PATH", "VIRTUAL_ENV")


def dropped_variables(platform: str) -> tuple[str, ...]:
    """What the worker must not inherit: the loader's library paths of the platform, and Python/GDAL/PROJ's."""
    if is_windows(platform):
        return COMMON_DROPPED  # extension DLLs do not follow PATH (Python >= 3.8); the wheels load their own
    if is_macos(platform):
        return ("DYLD_LIBRARY_PATH", "DYLD_FALLBACK_LIBRARY_PATH", "DYLD_INSERT_LIBRARIES", *COMMON_DROPPED)
    return ("LD_LIBRARY_PATH", "LD_PRELOAD", *COMMON_DROPPED)


def quote(arg: str, platform: str) -> str:
    """One shell argument as the platform's terminal takes it: as it is when it holds only safe characters,
    else in double quotes (cmd.exe) or single quotes (POSIX shells)."""
    text = str(arg)
    safe = r"[\w@+=:,./\\-]+" if is_windows(platform) else r"[\w@+=:,./-]+"  # a backslash is a path on Windows
    if re.fullmatch(safe, text):
        return text
    if is_windows(platform):
        return '"' + text.replace('"', '""') + '"'
    return "'" + text.replace("'", "'\\''") + "'"


def terminal_command(args, platform: str) -> str:
    return " ".join(quote(a, platform) for a in args)


def terminal_name(platform: str) -> str:
    if is_windows(platform):
        return "the OSGeo4W Shell (Start menu > QGIS > OSGeo4W Shell)"
    if is_macos(platform):
        return "Terminal"
    return "a terminal"


def missing_venv_fix(platform: str) -> str:
    """What to do when QGIS's Python cannot make a venv (no ``venv``/``ensurepip``), in the platform's words."""
    if is_windows(platform):
        return ("QGIS's Python lacks the venv module. Fix: run the OSGeo4W installer (Advanced Install) and add "
                "the python3-pip and python3-setuptools packages, or reinstall QGIS from qgis.org; or set "
                "FOTOGEO_PYTHON to a Python 3.10+ that has fotogeo's packages")
    if is_macos(platform):
        return ("QGIS.app's Python lacks the venv module. Fix: install the current QGIS package from qgis.org "
                "(its Python includes venv), or set FOTOGEO_PYTHON to a Python 3.10+ (python.org or Homebrew) "
                "that has fotogeo's packages")
    return ("Python's venv module is missing. Fix on Debian/Ubuntu: sudo apt install python3-venv; on Fedora: "
            "sudo dnf install python3-libs; then run Install / repair runtime again")


def missing_python_fix(platform: str) -> str:
    """What to do when no QGIS Python was found at all."""
    if is_windows(platform):
        return ("QGIS's python.exe was not found beside QGIS (apps\\Python3x). Fix: set FOTOGEO_PYTHON to a "
                "python.exe 3.10+ with fotogeo's packages, or repair the QGIS installation")
    if is_macos(platform):
        return ("QGIS.app/Contents/MacOS/bin/python3 was not found. Fix: install QGIS from qgis.org, or set "
                "FOTOGEO_PYTHON to a Python 3.10+ with fotogeo's packages")
    return "python3 was not found. Fix: install your distribution's python3 and python3-venv packages"
