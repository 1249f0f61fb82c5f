"""The QGIS runtime's platform logic (processing_provider/platforms.py) for Windows, macOS and Linux, tested
here on Linux: each function takes the platform and the facts it needs as arguments."""
from __future__ import annotations

from pathlib import PureWindowsPath

import importlib.util
import sys
from pathlib import Path

import pytest


def _load_plugin_module(name):
    """A module of processing_provider/ from its file, as scripts/qgis_install.py loads the runtime: the checkout
    root is not on sys.path in a plain venv where fotogeo is installed from a wheel."""
    path = Path(__file__).resolve().parents[1] / "processing_provider" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"fotogeo_plugin_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


pf = _load_plugin_module("platforms")

WIN_EXE = r"C:\OSGeo4W\bin\qgis-bin.exe"
WIN_PREFIX = r"C:\OSGeo4W\apps\Python312"
MAC_EXE = "/Applications/QGIS.app/Contents/MacOS/QGIS"
MAC_PREFIX = "/Applications/QGIS.app/Contents/Frameworks/Python.framework/Versions/3.10"


def test_venv_interpreter_per_platform():
    assert str(pf.venv_python(r"C:\Users\a\fotogeo-env", "win32")) == r"C:\Users\a\fotogeo-env\Scripts\python.exe"
    assert str(pf.venv_python("/Users/a/fotogeo-env", "darwin")) == "/Users/a/fotogeo-env/bin/python"
    assert str(pf.venv_python("/home/a/fotogeo-env", "linux")) == "/home/a/fotogeo-env/bin/python"


def test_qgis_python_on_windows_osgeo4w_and_standalone():
    """Inside QGIS sys.executable is qgis-bin.exe; QGIS's python.exe is sys.prefix (apps\\Python3x)."""
    found = pf.base_python("win32", WIN_EXE, WIN_PREFIX, {}, exists=lambda p: p == WIN_PREFIX + r"\python.exe")
    assert found == r"C:\OSGeo4W\apps\Python312\python.exe"
    # a standalone install whose prefix is unknown: found from the executable's root, apps\Python3x
    standalone = r"C:\Program Files\QGIS 3.40.1\apps\Python312\python.exe"
    found = pf.base_python("win32", r"C:\Program Files\QGIS 3.40.1\bin\qgis-bin.exe", r"C:\elsewhere", {},
                           exists=lambda p: p == standalone)
    assert found == standalone
    # OSGEO4W_ROOT names the root when set
    found = pf.base_python("win32", WIN_EXE, r"C:\x", {"OSGEO4W_ROOT": r"D:\O4W"},
                           exists=lambda p: p == r"D:\O4W\apps\Python311\python.exe")
    assert found == r"D:\O4W\apps\Python311\python.exe"
    assert pf.base_python("win32", WIN_EXE, WIN_PREFIX, {}, exists=lambda p: False, which=lambda n: "/x") is None


def test_qgis_python_on_macos():
    bundled = "/Applications/QGIS.app/Contents/MacOS/bin/python3"
    assert pf.base_python("darwin", MAC_EXE, MAC_PREFIX, {}, exists=lambda p: p == bundled) == bundled
    assert pf.base_python("darwin", MAC_EXE, MAC_PREFIX, {}, exists=lambda p: False,
                          which=lambda n: "/opt/homebrew/bin/python3") == "/opt/homebrew/bin/python3"


def test_qgis_python_on_linux():
    assert pf.base_python("linux", "/usr/bin/qgis", "/usr", {}, exists=lambda p: p == "/usr/bin/python3") == \
        "/usr/bin/python3"
    # run as a script by another Python (no /usr/bin/python3): that Python
    assert pf.base_python("linux", "/opt/py/bin/python3.12", "/opt/py", {},
                          exists=lambda p: p == "/opt/py/bin/python3.12") == "/opt/py/bin/python3.12"


def test_default_profile_per_platform():
    assert pf.default_profile("win32", r"C:\Users\a", {"APPDATA": r"C:\Users\a\AppData\Roaming"}) == \
        PureWindowsPath(r"C:\Users\a\AppData\Roaming\QGIS\QGIS3\profiles\default")
    assert str(pf.default_profile("darwin", "/Users/a")) == \
        "/Users/a/Library/Application Support/QGIS/QGIS3/profiles/default"
    assert str(pf.default_profile("linux", "/home/a")) == "/home/a/.local/share/QGIS/QGIS3/profiles/default"


def test_dropped_library_variables_per_platform():
    assert "DYLD_LIBRARY_PATH" in pf.dropped_variables("darwin") and "LD_LIBRARY_PATH" in pf.dropped_variables("linux")
    assert not {"LD_LIBRARY_PATH", "DYLD_LIBRARY_PATH", "PATH"} & set(pf.dropped_variables("win32"))
    for p in ("win32", "darwin", "linux"):
        assert {"PYTHONHOME", "PYTHONPATH", "GDAL_DATA", "PROJ_LIB"} <= set(pf.dropped_variables(p))


def test_fix_commands_are_quoted_for_the_platforms_terminal():
    args = [r"C:\Program Files\QGIS 3.40\apps\Python312\python.exe", r"C:\p\runtime.py", "install", r"C:\a b\env"]
    assert pf.terminal_command(args, "win32") == \
        r'"C:\Program Files\QGIS 3.40\apps\Python312\python.exe" C:\p\runtime.py install "C:\a b\env"'
    assert pf.terminal_command(["/x/python3", "/a b/it's", "install"], "darwin") == "/x/python3 '/a b/it'\\''s' install"
    assert "OSGeo4W Shell" in pf.terminal_name("win32") and pf.terminal_name("darwin") == "Terminal"


@pytest.mark.parametrize("platform, must, must_not", [
    ("win32", ["OSGeo4W", "FOTOGEO_PYTHON"], ["sudo", "apt"]),
    ("darwin", ["qgis.org", "FOTOGEO_PYTHON"], ["sudo", "apt"]),
    ("linux", ["sudo apt install python3-venv"], ["OSGeo4W"]),
])
def test_fixes_name_the_platforms_remedy(platform, must, must_not):
    for text in (pf.missing_venv_fix(platform), pf.missing_python_fix(platform)):
        assert not any(m in text for m in must_not), text
    assert all(m in pf.missing_venv_fix(platform) for m in must), pf.missing_venv_fix(platform)


def test_runtime_uses_the_platform_layer(monkeypatch, tmp_path):
    """runtime.resolve / fix_command follow PLATFORM: a Windows runtime is Scripts\\python.exe."""
    rt = _load_plugin_module("runtime")
    monkeypatch.delenv("FOTOGEO_PYTHON", raising=False)
    monkeypatch.delenv("FOTOGEO_RUNTIME", raising=False)
    monkeypatch.setattr(rt, "PLATFORM", "win32")
    r = rt.resolve(tmp_path / "profile")
    assert str(r.python).endswith("\\Scripts\\python.exe")  # a WindowsPath on Windows, text-checked here
    assert rt.fix_command(r).endswith(" install " + str(r.folder)) and "OSGeo4W Shell" in rt.status(r)[1]
    monkeypatch.setattr(rt, "PLATFORM", "linux")
    assert rt.resolve(tmp_path / "profile").python.parts[-2:] == ("bin", "python")
