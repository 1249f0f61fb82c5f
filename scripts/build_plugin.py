"""Build the installable QGIS plugin: ``dist/fotogeo_qgis.zip``.

    python scripts/build_plugin.py [--output dist/fotogeo_qgis.zip]

The zip holds one top-level folder ``fotogeo_qgis/`` (the plugin's package name):

- ``__init__.py`` — the plugin entry (``classFactory``), which puts the folder on
  ``sys.path`` so that the vendored ``fotogeo`` package imports as ``fotogeo``;
- ``metadata.txt`` — from the repository root, its ``version`` written from pyproject.toml (the one
  version source; tests/test_packaging.py checks that the checkout's metadata.txt agrees);
- ``processing_provider/`` — the provider, its algorithms and ``styles/*.qml``;
- ``fotogeo/`` — the pure-Python fotogeo package, without its command line (``cli``, which
  needs click), so the plugin works with only the third-party packages installed
  (numpy, rasterio, pyproj, shapely, geopandas, opencv-python-headless).

Install: QGIS > Plugins > Manage and Install Plugins > Install from ZIP, or unzip into the
profile's ``python/plugins`` folder. Entries are sorted and time-stamped 1980-01-01, so the
same sources give the same zip.
"""
from __future__ import annotations

import argparse
import configparser
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = "fotogeo_qgis"
EXCLUDE_DIRS = {"__pycache__", ".pytest_cache"}
EXCLUDE_FOTOGEO = {"cli"}  # command line only (click); the plugin calls the tools directly
# what QGIS needs to install and load a plugin, and what plugins.qgis.org requires of an upload
# (tests/test_plugin_metadata.py checks the repository's rules)
REQUIRED_METADATA = ("name", "qgisMinimumVersion", "qgisMaximumVersion", "description", "about", "version",
                     "author", "email", "repository", "tracker", "hasProcessingProvider", "license")
PLACEHOLDER_HOSTS = ("example.org", "example.com")

ENTRY = '''"""fotogeo QGIS plugin (built by scripts/build_plugin.py from the fotogeo repository).

The vendored pure-Python ``fotogeo`` package beside this file is imported as ``fotogeo``:
this folder goes first on ``sys.path`` so that the provider always runs the fotogeo it was
built with.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)


def classFactory(iface):  # noqa: N802 - the name QGIS looks for
    from .processing_provider.plugin import classFactory as factory
    return factory(iface)
'''


def fotogeo_version() -> str:
    """``version`` of pyproject.toml's ``[project]`` table."""
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    table = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, re.MULTILINE | re.DOTALL)
    m = table and re.search(r'^version\s*=\s*["\']([^"\']+)["\']', table.group(1), re.MULTILINE)
    if not m:
        sys.exit("build_plugin: no version in pyproject.toml's [project] table")
    return m.group(1)


def metadata_with_version(text: str, version: str) -> str:
    """metadata.txt with its ``version=`` line set to *version* (added when missing)."""
    if re.search(r"^version\s*=.*$", text, re.MULTILINE):
        return re.sub(r"^version\s*=.*$", f"version={version}", text, count=1, flags=re.MULTILINE)
    return text.replace("[general]\n", f"[general]\nversion={version}\n", 1)


def check_metadata(path: Path) -> configparser.ConfigParser:
    cp = configparser.ConfigParser()
    cp.optionxform = str  # keys are case-sensitive (qgisMinimumVersion)
    cp.read(path, encoding="utf-8")
    if "general" not in cp:
        sys.exit(f"build_plugin: {path} has no [general] section")
    missing = [k for k in REQUIRED_METADATA if not cp["general"].get(k, "").strip()]
    if missing:
        sys.exit(f"build_plugin: {path} lacks {', '.join(missing)}")
    placeholders = [k for k, v in cp["general"].items() if any(h in v for h in PLACEHOLDER_HOSTS)]
    if placeholders:
        sys.exit(f"build_plugin: {path} has placeholder values in {', '.join(placeholders)}")
    return cp


def _walk(folder: Path, skip_top: set[str] = frozenset()):
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder)
        if not p.is_file() or set(rel.parts) & EXCLUDE_DIRS or (rel.parts and rel.parts[0] in skip_top):
            continue
        if p.suffix in (".pyc", ".pyo") or p.name.startswith("."):
            continue
        yield p, rel


def plugin_files() -> list[tuple[str, bytes]]:
    """``(path in the zip, bytes)`` of every file of the plugin, sorted (``fotogeo_qgis/...``)."""
    check_metadata(ROOT / "metadata.txt")
    entries: list[tuple[str, bytes]] = [(f"{PLUGIN}/__init__.py", ENTRY.encode()),
                                        (f"{PLUGIN}/metadata.txt", metadata_with_version(
                                            (ROOT / "metadata.txt").read_text(encoding="utf-8"),
                                            fotogeo_version()).encode("utf-8"))]
    for p, rel in _walk(ROOT / "processing_provider"):
        entries.append((f"{PLUGIN}/processing_provider/{rel.as_posix()}", p.read_bytes()))
    for p, rel in _walk(ROOT / "fotogeo", EXCLUDE_FOTOGEO):
        if p.suffix == ".py":
            entries.append((f"{PLUGIN}/fotogeo/{rel.as_posix()}", p.read_bytes()))
    for extra in ("LICENSE", "LICENSE.txt", "COPYING"):
        if (ROOT / extra).is_file():
            entries.append((f"{PLUGIN}/{extra}", (ROOT / extra).read_bytes()))
    return sorted(entries)


def build(output: Path) -> Path:
    entries = plugin_files()
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(f".{output.name}.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in sorted(entries):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, data)
    tmp.replace(output)
    return output


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--output", type=Path, default=ROOT / "dist" / f"{PLUGIN}.zip")
    ap.add_argument("--sync-metadata", action="store_true",
                    help="write pyproject.toml's version into the checkout's metadata.txt and stop")
    args = ap.parse_args(argv)
    if args.sync_metadata:
        path = ROOT / "metadata.txt"
        path.write_text(metadata_with_version(path.read_text(encoding="utf-8"), fotogeo_version()), encoding="utf-8")
        print(f"{path}: version={fotogeo_version()}")
        return 0
    out = build(args.output)
    with zipfile.ZipFile(out) as z:
        n = len(z.namelist())
    print(f"wrote {out} ({n} files, {out.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
