"""fotogeo's runtime for QGIS: an isolated Python environment the plugin creates and runs fotogeo in.

Standard library only: it runs inside QGIS (the plugin's *Install / repair runtime* action),
from ``make qgis-install`` and as a script (``python3 runtime.py install|status``).

Why out of process. Debian's ``qgis`` and ``qgis_process`` load QGIS's own GDAL 3.6, GEOS
and PROJ before any plugin code runs; the pip wheels fotogeo needs (rasterio, pyogrio,
shapely, pyproj) bundle newer copies of the same libraries, and inside QGIS's process they
get displaced (pyogrio: "Could not correctly detect GDAL data files installed by pyogrio
wheel"; shapely: "WKB output dimension must be 2 or 3"). Debian's own python3-shapely,
-geopandas and -opencv are older than fotogeo needs and there is no python3-pyogrio; building
the wheels against QGIS's libraries needs compilers and -dev packages. So the plugin keeps
fotogeo's dependencies in a venv of their own (``/usr/bin/python3 -m venv``, binary wheels
only: no compiler, no sudo) and runs each tool there as ``python -m fotogeo.worker``, with the
plugin's bundled fotogeo on ``PYTHONPATH`` (so the worker always runs the code the provider
was built with) and without QGIS's library variables. Each process loads its own libraries;
results come back as JSON.

Where: ``<profile>/python/fotogeo-env`` by default (removed with the profile), or the folder
named by the profile setting ``fotogeo/runtime`` or the environment variable
``FOTOGEO_RUNTIME``. ``FOTOGEO_PYTHON`` names a ready interpreter instead (a developer's venv).
A stamp file records the requirements it was built from and the worker's environment check.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

try:  # a module of the plugin package, or a script or a file loaded from its folder (python3 runtime.py install)
    from . import platforms
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import platforms

PACKAGE_DIR = Path(__file__).resolve().parent
#: the folder holding ``processing_provider/`` and the bundled ``fotogeo/`` package
PLUGIN_ROOT = PACKAGE_DIR.parent
REQUIREMENTS = PACKAGE_DIR / "runtime-requirements.txt"
STAMP = "fotogeo-runtime.json"
ENV_FOLDER = "fotogeo-env"
SETTING = "fotogeo/runtime"
#: the operating system (``sys.platform``); the path and message logic lives in platforms.py, tested per platform
PLATFORM = sys.platform
#: variables of QGIS's process that would make the worker's wheels load or read QGIS's libraries and data
DROPPED_VARIABLES = platforms.dropped_variables(PLATFORM)


class RuntimeInstallError(RuntimeError):
    """The runtime could not be built; the message names what is missing and the fix."""


def system_python() -> str | None:
    """QGIS's own Python, which makes the venv (inside QGIS ``sys.executable`` is QGIS itself): platforms.py."""
    return platforms.base_python(PLATFORM, sys.executable, sys.base_prefix, os.environ, os.path.exists, shutil.which)


def requirements_digest() -> str:
    return hashlib.sha256(REQUIREMENTS.read_bytes()).hexdigest()[:16]


@dataclass(frozen=True)
class Runtime:
    """Where fotogeo runs: a managed venv ``folder``, or a given interpreter (``managed`` False)."""

    python: Path
    folder: Path | None = None

    @property
    def managed(self) -> bool:
        return self.folder is not None

    @property
    def stamp(self) -> Path | None:
        return self.folder / STAMP if self.folder else None


def resolve(profile_dir=None, configured=None) -> Runtime:
    """``FOTOGEO_PYTHON`` > ``FOTOGEO_RUNTIME`` > the profile setting > ``<profile>/python/fotogeo-env``."""
    if os.environ.get("FOTOGEO_PYTHON"):
        return Runtime(Path(os.environ["FOTOGEO_PYTHON"]))
    folder = os.environ.get("FOTOGEO_RUNTIME") or configured
    if not folder:
        base = Path(profile_dir) if profile_dir else Path(str(platforms.default_profile(PLATFORM, str(Path.home()),
                                                                                      os.environ)))
        folder = base / "python" / ENV_FOLDER
    folder = Path(folder).expanduser()
    return Runtime(Path(str(platforms.venv_python(folder, PLATFORM))), folder)


def fix_command(runtime: Runtime) -> str:
    """The one command that (re)builds ``runtime``, quoted for the platform's terminal (platforms.py)."""
    py = system_python() or ("python" if platforms.is_windows(PLATFORM) else "python3")
    return platforms.terminal_command([py, str(PACKAGE_DIR / "runtime.py"), "install", str(runtime.folder)], PLATFORM)


def _in_terminal() -> str:
    return f"or in {platforms.terminal_name(PLATFORM)}"


def status(runtime: Runtime) -> tuple[bool, str]:
    """``(usable, message)`` without starting a process: the stamp says what the last check found."""
    if not runtime.python.exists():
        where = f"fotogeo's runtime {runtime.folder}" if runtime.managed else f"FOTOGEO_PYTHON {runtime.python}"
        return False, (f"{where} is not installed. Fix: menu fotogeo > Install / repair runtime, "
                       f"{_in_terminal()}: {fix_command(runtime) if runtime.managed else 'unset FOTOGEO_PYTHON'}")
    if not runtime.managed:
        return True, f"fotogeo runs in {runtime.python} (FOTOGEO_PYTHON)"
    try:
        stamp = json.loads(runtime.stamp.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        stamp = {}
    if stamp.get("requirements") != requirements_digest():
        why = "was never completed" if not stamp else "was built for other requirements (the plugin was updated)"
        return False, (f"fotogeo's runtime {runtime.folder} {why}. Fix: menu fotogeo > Install / repair "
                       f"runtime, {_in_terminal()}: {fix_command(runtime)}")
    check = stamp.get("check", {})
    if not check.get("ok"):
        return False, (f"fotogeo's runtime {runtime.folder} failed its check: {'; '.join(check.get('problems', []))}"
                       f". Fix: menu fotogeo > Install / repair runtime, or: {fix_command(runtime)}")
    return True, f"fotogeo runs in {runtime.folder} ({describe_libraries(check)})"


def describe_libraries(check: dict) -> str:
    """'GDAL (rasterio) 3.10.3, GEOS (shapely) 3.14.1, ...' from a worker check."""
    return ", ".join(f"{k} {v}" for k, v in check.get("libraries", {}).items())


def worker_environment(environ=None) -> dict:
    """The worker's environment: ``environ`` without QGIS's library variables, fotogeo on ``PYTHONPATH``,
    GDAL's PAM off (the worker never writes an ``.aux.xml`` beside an input: :mod:`.side_files`)."""
    env = {k: v for k, v in (os.environ if environ is None else environ).items() if k not in DROPPED_VARIABLES}
    env["PYTHONPATH"] = str(PLUGIN_ROOT)
    env["GDAL_PAM_ENABLED"] = "NO"
    env["PYTHONNOUSERSITE"] = "1"
    return env


def worker_command(runtime: Runtime, *extra: str) -> list[str]:
    return [str(runtime.python), "-m", "fotogeo.worker", *extra]


def check(runtime: Runtime, timeout: float = 120) -> dict:
    """Run the worker's environment check (``python -m fotogeo.worker --check``) in ``runtime``."""
    try:
        done = subprocess.run(worker_command(runtime, "--check"), capture_output=True, text=True, timeout=timeout,
                              env=worker_environment(), cwd=str(PLUGIN_ROOT))
    except (OSError, subprocess.TimeoutExpired) as e:
        return {"ok": False, "problems": [f"the worker did not start or answer: {e}"]}
    try:
        return json.loads(done.stdout)
    except ValueError:
        tail = " ".join(done.stderr.strip().splitlines()[-3:])
        return {"ok": False, "problems": [f"the worker failed (exit {done.returncode}): {tail}"]}


#: pip's output lines that name a step (the others — warnings, notices, dependency details — go to the log only)
_PIP_STEPS = (("Collecting ", "collecting {}"), ("Downloading ", "downloading {}"), ("Using cached ", "cached: {}"),
              ("Requirement already satisfied: ", "already installed: {}"),
              ("Installing collected packages", "installing the packages"), ("Successfully installed", "installed"))


def pip_step(line: str) -> str | None:
    """The step a pip output line names, in a few words, or None (module docstring of the install).

    >>> pip_step("Collecting rasterio>=1.3 (from -r requirements.txt (line 2))")
    'collecting rasterio>=1.3'
    >>> pip_step("Downloading https://files.example/ab/numpy-1.26.4-cp311-manylinux.whl (18.3 MB)")
    'downloading numpy-1.26.4-cp311-manylinux.whl (18.3 MB)'
    >>> pip_step("  WARNING: The script f2py is installed in '/x/bin' which is not on PATH.") is None
    True
    """
    text = line.strip()
    for prefix, form in _PIP_STEPS:
        if text.startswith(prefix):
            rest = text[len(prefix):].split(" (from", 1)[0].strip()
            if prefix == "Downloading ":
                rest = rest.rsplit("/", 1)[-1]
            elif "{}" in form:
                rest = rest.split()[0] if rest else ""
            return form.format(rest)[:70]
    return None


def _run_logged(command, log, progress=None, span=(0.0, 1.0), expected_lines: int = 60):
    """Run ``command``, passing its output lines to ``log``; advance ``progress`` per line, naming the step of
    the lines that name one (:func:`pip_step`) — never a warning cut short."""
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=worker_environment(), cwd=str(PLUGIN_ROOT))
    lines, step = [], "pip"
    for i, line in enumerate(proc.stdout):
        line = line.rstrip()
        lines.append(line)
        log(line)
        step = pip_step(line) or step
        if progress is not None and progress(span[0] + (span[1] - span[0]) * min(i / expected_lines, 0.99),
                                             step) is False:
            proc.terminate()
            proc.wait()
            raise RuntimeInstallError("cancelled")
    if proc.wait() != 0:
        raise RuntimeInstallError(f"{' '.join(map(str, command[:4]))} … failed (exit {proc.returncode}): "
                                  + " | ".join(lines[-4:]))


def install(runtime: Runtime, log=print, progress=None) -> dict:
    """Create or repair the venv of ``runtime``, install the pinned wheels, check it, write the stamp.

    ``progress(fraction, message) -> bool`` (False cancels). Returns the worker's check.
    Needs Debian's ``python3-venv`` (names it when missing) and access to PyPI or a wheel cache.
    """
    if not runtime.managed:
        raise RuntimeInstallError(f"FOTOGEO_PYTHON={runtime.python} is a given interpreter, not a managed "
                                  f"runtime; unset FOTOGEO_PYTHON to let fotogeo manage its own")
    progress = progress or (lambda f, m: True)
    py = system_python()
    if py is None:
        raise RuntimeInstallError(platforms.missing_python_fix(PLATFORM))
    if subprocess.run([py, "-c", "import ensurepip, venv"], capture_output=True).returncode != 0:
        raise RuntimeInstallError(platforms.missing_venv_fix(PLATFORM))
    folder = runtime.folder
    healthy = runtime.python.exists() and subprocess.run(
        [str(runtime.python), "-c", "import pip"], capture_output=True).returncode == 0
    if not healthy:
        progress(0.02, f"creating the venv {folder}")
        folder.parent.mkdir(parents=True, exist_ok=True)
        _run_logged([py, "-m", "venv", "--clear", str(folder)], log)
    if runtime.stamp.exists():
        runtime.stamp.unlink()
    progress(0.05, "installing fotogeo's dependencies (binary wheels)")
    _run_logged([str(runtime.python), "-m", "pip", "install", "--disable-pip-version-check", "--no-input",
                 "--only-binary=:all:", "-r", str(REQUIREMENTS)], log, progress, (0.05, 0.9))
    progress(0.92, "checking the runtime (versions, GDAL/GEOS/PROJ, a smoke test)")
    result = check(runtime)
    log(f"check: {'ok' if result.get('ok') else 'FAILED'}; {describe_libraries(result)}")
    if not result.get("ok"):
        raise RuntimeInstallError(f"the runtime {folder} was built but fails its check: "
                                  + "; ".join(result.get("problems", [])))
    runtime.stamp.write_text(json.dumps({"requirements": requirements_digest(), "check": result,
                                         "created": time.strftime("%Y-%m-%d %H:%M:%S")}, indent=1), encoding="utf-8")
    progress(1.0, "fotogeo's runtime is ready")
    return result


def set_ini_value(path, section: str, key: str, value: str) -> None:
    """Set ``key=value`` in ``[section]`` of a QSettings INI file, leaving every other line as it is."""
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines() if path.exists() else []
    header = f"[{section}]"
    if header not in (line.strip() for line in lines):
        lines += ([""] if lines and lines[-1].strip() else []) + [header, f"{key}={value}"]
    else:
        start = next(i for i, line in enumerate(lines) if line.strip() == header) + 1
        end = next((i for i in range(start, len(lines)) if lines[i].startswith("[")), len(lines))
        hit = next((i for i in range(start, end) if lines[i].split("=", 1)[0].strip() == key), None)
        if hit is None:
            while end > start and not lines[end - 1].strip():
                end -= 1
            lines.insert(end, f"{key}={value}")
        else:
            lines[hit] = f"{key}={value}"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(description="fotogeo's runtime for QGIS: install or show it")
    ap.add_argument("command", choices=("install", "status", "check"))
    ap.add_argument("folder", nargs="?", help="runtime folder [<profile>/python/fotogeo-env]")
    ap.add_argument("--profile", help="QGIS profile folder [the default profile]")
    args = ap.parse_args(argv)
    runtime = resolve(args.profile, args.folder)
    try:
        if args.command == "install":
            install(runtime)
        elif args.command == "check":
            print(json.dumps(check(runtime), indent=1))
            return 0
    except RuntimeInstallError as e:
        print(f"Error: {e}", file=sys.stderr)
        return 2
    ok, message = status(runtime)
    print(message)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
