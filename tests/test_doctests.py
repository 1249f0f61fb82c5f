"""The docstring examples of every ``fotogeo`` module run as tests (one test per module).

Modules are found on disk, not by importing the package, so a module that fails to import
fails its own test instead of stopping collection. ``processing_provider`` is not walked:
it imports QGIS and is tested by the ``qgis`` tests.
"""
from __future__ import annotations

import doctest
import importlib
import io
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fotogeo"
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _module_names() -> list[str]:
    names = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


MODULES = _module_names()


def _examples(module) -> list[doctest.DocTest]:
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, module.__name__)
    return [t for t in tests if t.examples]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    out = io.StringIO()
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in _examples(module):
        runner.run(test, out=out.write)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, out.getvalue()


def test_the_examples_are_found():
    """The walk sees the package (guards against a silent zero-module run) and the modules
    whose docstrings document an interface by example still carry examples."""
    assert "fotogeo.tools.register.tool" in MODULES and "fotogeo" in MODULES
    documented = ("fotogeo", "fotogeo.pixels", "fotogeo.crs", "fotogeo.progress", "fotogeo.models.base",
                  "fotogeo.image.fusion", "fotogeo.features.surf", "fotogeo.io.points")
    for name in documented:
        assert _examples(importlib.import_module(name)), f"{name} has no docstring examples"
