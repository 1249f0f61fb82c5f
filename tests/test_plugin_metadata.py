"""metadata.txt and the plugin zip against the rules plugins.qgis.org applies to an upload (mandatory fields,
versions, one-line description, URLs, the zip's layout), so an upload is not refused."""
from __future__ import annotations

import configparser
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MANDATORY = ("name", "qgisMinimumVersion", "description", "about", "version", "author", "email", "repository",
             "tracker")


@pytest.fixture(scope="module")
def meta() -> configparser.SectionProxy:
    cp = configparser.ConfigParser()
    cp.optionxform = str
    cp.read(ROOT / "metadata.txt", encoding="utf-8")
    return cp["general"]


@pytest.fixture(scope="module")
def build_plugin():
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import build_plugin
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    return build_plugin


def _version_tuple(text: str) -> tuple:
    return tuple(int(x) for x in text.split("."))


def test_mandatory_fields(meta):
    missing = [k for k in MANDATORY if not meta.get(k, "").strip()]
    assert not missing, f"metadata.txt lacks {missing}"


def test_qgis_versions_cover_3_22_to_qgis_4(meta):
    lo, hi = meta["qgisMinimumVersion"], meta["qgisMaximumVersion"]
    assert re.fullmatch(r"\d+\.\d+", lo) and re.fullmatch(r"\d+\.\d+", hi)
    assert lo == "3.22" and hi == "4.99" and _version_tuple(lo) < _version_tuple(hi)
    assert meta.get("supportsQt6") == "True"  # QGIS 4 (Qt6) lists only plugins that say so


def test_description_is_one_line_and_about_says_more(meta):
    d, a = meta["description"], meta["about"]
    assert "\n" not in d.strip() and len(d) <= 200 and d.endswith(".")
    assert len(a) > 3 * len(d) and a != d and "\n" not in a.strip()
    assert "no public homepage" not in a.lower()


def test_version_follows_pyproject_and_is_a_release_number(meta, build_plugin):
    assert re.fullmatch(r"\d+\.\d+\.\d+(?:[.-]?(?:a|b|rc|dev)\d*)?", meta["version"])
    assert meta["version"] == build_plugin.fotogeo_version()


def test_contacts_and_urls(meta):
    assert re.fullmatch(r"[^@\s]+@[^@\s]+\.[a-z]{2,}", meta["email"])
    for key in ("homepage", "repository", "tracker"):
        assert re.fullmatch(r"https://[^\s]+", meta[key]), key
        assert "example." not in meta[key], key
    if sys.version_info >= (3, 11):
        import tomllib
        project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
        urls = project["urls"]
        assert meta["repository"] == urls["Repository"] and meta["tracker"] == urls["Issues"]
        assert meta["homepage"] == urls["Homepage"] and meta["email"] == project["authors"][0]["email"]


def test_flags_icon_and_category(meta):
    for key in ("experimental", "deprecated"):
        assert meta[key] in ("True", "False"), key
    assert meta["hasProcessingProvider"] == "yes" and meta["category"] in ("Analysis", "Raster", "Vector", "Web",
                                                                          "Database", "Mesh", "Plugins")
    assert (ROOT / meta["icon"]).is_file()
    assert all(t.strip() == t.strip().lower() for t in meta["tags"].split(","))


def test_zip_layout_the_repository_accepts(build_plugin):
    """One top folder named as a Python package, metadata.txt and LICENSE in it, no caches or VCS files."""
    names = [n for n, _ in build_plugin.plugin_files()]
    tops = {n.split("/")[0] for n in names}
    assert tops == {build_plugin.PLUGIN} and build_plugin.PLUGIN.isidentifier()
    assert f"{build_plugin.PLUGIN}/metadata.txt" in names and f"{build_plugin.PLUGIN}/LICENSE" in names
    bad = [n for n in names if re.search(r"(__pycache__|\.pyc$|(^|/)\.git|__MACOSX|\.DS_Store)", n)]
    assert not bad, bad
    assert build_plugin.REQUIRED_METADATA and set(MANDATORY) <= set(build_plugin.REQUIRED_METADATA)
