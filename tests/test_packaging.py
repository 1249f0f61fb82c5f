"""The package's metadata: one version source, the licence, the extras, the files a wheel must carry."""
from __future__ import annotations

import configparser
import re
import sys
from pathlib import Path

import pytest

import fotogeo

ROOT = Path(__file__).resolve().parents[1]

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = None


def _project() -> dict:
    if tomllib is None:
        pytest.skip("tomllib needs Python 3.11")
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]


def _metadata_txt() -> configparser.SectionProxy:
    cp = configparser.ConfigParser()
    cp.optionxform = str
    cp.read(ROOT / "metadata.txt", encoding="utf-8")
    return cp["general"]


def test_one_version_everywhere():
    """pyproject's version is what ``fotogeo.__version__``, ``fotogeo --version``, metadata.txt and CITATION.cff say."""
    from click.testing import CliRunner

    from fotogeo.cli import main
    version = _project()["version"]
    assert fotogeo.__version__ == version
    assert _metadata_txt()["version"] == version, "metadata.txt: run python scripts/build_plugin.py --sync-metadata"
    assert re.search(rf"^version: {re.escape(version)}$", (ROOT / "CITATION.cff").read_text(encoding="utf-8"), re.M)
    r = CliRunner().invoke(main, ["--version"])
    assert r.exit_code == 0 and version in r.output


def test_version_fallbacks(tmp_path, monkeypatch):
    """Outside a checkout and without installed metadata, the plugin zip's metadata.txt gives the version."""
    from fotogeo import _version
    assert _version._from_pyproject(tmp_path / "missing.toml") is None
    other = tmp_path / "pyproject.toml"
    other.write_text('[project]\nname = "other"\nversion = "9.9"\n')
    assert _version._from_pyproject(other) is None  # another project's pyproject is not ours
    other.write_text('[build-system]\nrequires = []\n[project]\nname = "fotogeo"\nversion = "1.2.3"\n[tool.x]\n'
                     'version = "0"\n')
    assert _version._from_pyproject(other) == "1.2.3"
    (tmp_path / "metadata.txt").write_text("[general]\nname=fotogeo\nversion=4.5.6\n")
    assert _version._from_plugin_metadata(tmp_path / "metadata.txt") == "4.5.6"


def test_pep639_licence_classifiers_urls_extras():
    p = _project()
    assert p["license"] == "GPL-3.0-or-later" and p["license-files"] == ["LICENSE"]
    assert not [c for c in p["classifiers"] if c.startswith("License ::")]  # PEP 639: the expression only
    versions = {c.rsplit(" ", 1)[-1] for c in p["classifiers"] if re.match(r"Programming Language :: Python :: 3\.\d+$", c)}
    assert versions == {"3.10", "3.11", "3.12", "3.13"} and p["requires-python"] == ">=3.10"
    assert {"Homepage", "Repository", "Issues", "Documentation"} <= set(p["urls"])
    extras = p["optional-dependencies"]
    assert any(d.startswith("matplotlib") for d in extras["plots"])
    assert any(d.startswith("mkdocs") for d in extras["docs"])
    assert not any(re.search(r"numpy\s*<|opencv.*<|affine\s*<", d) for d in p["dependencies"])


def test_py_typed_ships():
    assert (Path(fotogeo.__file__).parent / "py.typed").is_file()


def test_caps_only_in_the_debian_venv_with_their_reasons():
    """numpy < 2, opencv < 4.12 and affine < 3 bound the Debian dev venv only (constraints.txt), each with its
    reason on the comment lines above it; the QGIS runtime (an isolated venv) takes today's wheels."""
    runtime = (ROOT / "processing_provider" / "runtime-requirements.txt").read_text(encoding="utf-8")
    assert not re.search(r"^(numpy|opencv[\w-]*|affine)[^#\n]*<", runtime, re.M), runtime
    lines = (ROOT / "constraints.txt").read_text(encoding="utf-8").splitlines()
    for i, line in enumerate(lines):
        if line.strip() and not line.startswith("#"):
            above = [x for x in lines[max(0, i - 6):i] if x.startswith("#")]
            assert above, f"constraints.txt: {line!r} has no reason written above it"


@pytest.mark.skipif(sys.platform == "win32", reason="the build script runs on the Linux/macOS development machines")
def test_plugin_zip_takes_pyproject_version(tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import build_plugin
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    text = "[general]\nname=fotogeo\nversion=0.0.1\nauthor=x\n"
    assert "version=7.0" in build_plugin.metadata_with_version(text, "7.0")
    assert build_plugin.metadata_with_version(text, "7.0").count("version=") == 1
    assert build_plugin.fotogeo_version() == _project()["version"]
