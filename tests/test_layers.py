"""Imports go down the layers (DESIGN.md, the layer table): no module of an array layer imports the file-format
layer, the tools, the CLI or the worker — neither at the top nor inside a function (a lazy import is still a
circle). Read from the source (AST), so a new upward import fails here before it works by accident."""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "fotogeo"
ARRAY_LAYERS = ("image", "geometry", "features", "matching", "mosaic", "coreg", "models", "orientation", "stereo")
ABOVE_ARRAYS = ("io", "tools", "cli", "worker")


def _imported(path: Path, root: Path = PACKAGE) -> set:
    """Every fotogeo subpackage ``path`` (a module under ``root``, the package folder) imports, absolute or
    relative, by its first name under ``fotogeo``."""
    names = set()
    here = path.relative_to(root).parts
    depth = len(here) - 1  # folders below fotogeo/
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = [] if node.level - 1 > depth else list(here[:depth - node.level + 1])
                parts += (node.module or "").split(".") if node.module else []
                if not node.module:
                    parts += [a.name for a in node.names]
            elif (node.module or "").startswith("fotogeo."):
                parts = node.module.split(".")[1:]
            else:
                continue
            names.add(parts[0] if parts else "")
        elif isinstance(node, ast.Import):
            names.update(a.name.split(".")[1] for a in node.names if a.name.startswith("fotogeo."))
    return names


@pytest.mark.parametrize("layer", ARRAY_LAYERS)
def test_array_layers_import_nothing_above_them(layer):
    upward = {str(p.relative_to(PACKAGE)): sorted(_imported(p) & set(ABOVE_ARRAYS))
              for p in sorted((PACKAGE / layer).rglob("*.py"))}
    assert {k: v for k, v in upward.items() if v} == {}


def test_the_checker_sees_a_lazy_upward_import(tmp_path):
    """The AST reader finds an import inside a function, relative or absolute (the old ``Dem.open``)."""
    fake = tmp_path / "fotogeo" / "geometry" / "x.py"
    fake.parent.mkdir(parents=True)
    fake.write_text("def f():\n    from ..io.raster import read_dem\n    import fotogeo.tools.rectify\n"
                    "    from . import camera\n")
    assert _imported(fake, tmp_path / "fotogeo") == {"io", "tools", "geometry"}
