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
    fake.write_text("def f():\n    from ..io.raster import read_dem\n    import fotogeo.tools.orient.rectify\n"
                    "    from . import camera\n")
    assert _imported(fake, tmp_path / "fotogeo") == {"io", "tools", "geometry"}


# -- the whole graph: layers in order, and no circle ------------------------------------------------------------
#: fotogeo's layers from the ground up (DESIGN.md, "Architecture"); a module may import its own layer or one below
LAYERS = {**dict.fromkeys(("_version", "errors", "progress", "pixels", "image_extent", "crs",
                               "options"), 0),
          **dict.fromkeys(ARRAY_LAYERS + ("stereo",), 1), "io": 2, "tools": 3, "cli": 4, "worker": 4}


def _modules(root: Path = PACKAGE) -> dict:
    """``{dotted module name: path}`` of every module under ``root`` (a package's is its ``__init__.py``)."""
    out = {}
    for p in root.rglob("*.py"):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def _graph(root: Path = PACKAGE) -> dict:
    """``{module: set of fotogeo modules it imports}``, lazy imports inside functions included; ``from a import b``
    points at the module ``a.b`` when there is one, else at ``a``."""
    mods = _modules(root)
    graph = {m: set() for m in mods}
    for m, p in mods.items():
        package = m.split(".") if p.name == "__init__.py" else m.split(".")[:-1]
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = package[:len(package) - node.level + 1] if node.level else []
                base = ".".join(base + (node.module.split(".") if node.module else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            graph[m].update(t for t in targets if t in mods and t != m)
    return graph


def _circles(graph: dict) -> list:
    """The strongly connected components with more than one module (Tarjan 1972), each sorted."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_circles():
    assert _circles(_graph()) == []


def test_no_module_imports_a_layer_above_its_own():
    def layer(module):
        parts = module.split(".")
        return LAYERS.get(parts[1]) if len(parts) > 1 else None

    upward = sorted(f"{m} -> {t}" for m, ts in _graph().items() for t in ts
                    if layer(m) is not None and layer(t) is not None and layer(t) > layer(m))
    assert upward == []


def test_every_top_level_name_has_a_layer():
    """A new top-level module or package is placed in :data:`LAYERS` (and DESIGN.md) before it lands; at most eight
    flat modules stay at the top, the rest live in packages."""
    top = {p.stem for p in PACKAGE.glob("*.py") if p.stem not in ("__init__", "__main__")}
    top |= {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert top <= set(LAYERS)
    assert len({p for p in PACKAGE.glob("*.py") if p.stem != "__init__"}) <= 8


def test_the_circle_finder_sees_a_lazy_circle(tmp_path):
    pkg = tmp_path / "fotogeo"
    (pkg / "tools").mkdir(parents=True)
    for f in ("__init__.py", "tools/__init__.py"):
        (pkg / f).write_text("")
    (pkg / "tools" / "a.py").write_text("from .b import x\n")
    (pkg / "tools" / "b.py").write_text("def x():\n    from . import a\n")
    (pkg / "tools" / "c.py").write_text("from fotogeo.tools import a\n")
    assert _circles(_graph(pkg)) == [["fotogeo.tools.a", "fotogeo.tools.b"]]


def test_tools_are_capability_packages():
    """Every tool lives in a capability package under ``fotogeo/tools/`` (shared helpers in ``tools/common``)."""
    flat = sorted(p.name for p in (PACKAGE / "tools").glob("*.py") if p.name != "__init__.py")
    assert flat == []
    for pkg in (p for p in (PACKAGE / "tools").iterdir() if p.is_dir() and p.name != "__pycache__"):
        init = pkg / "__init__.py"
        assert init.exists() and ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))), \
            f"{pkg.name}/__init__.py must say what the package offers"


def _body_lines(fn) -> int:
    """A function's length in lines without its docstring."""
    first = fn.body[0]
    doc = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str)
    return fn.end_lineno - fn.lineno + 1 - ((first.end_lineno - first.lineno + 1) if doc else 0)


def test_modules_and_functions_stay_short():
    """Modules of at most 400 lines and functions of at most 80 (docstrings aside), in fotogeo and the plugin."""
    roots = (PACKAGE, PACKAGE.parent / "processing_provider")
    long_modules, long_functions = [], []
    for path in (p for r in roots for p in sorted(r.rglob("*.py"))):
        text = path.read_text(encoding="utf-8")
        if len(text.splitlines()) > 400:
            long_modules.append(str(path.relative_to(PACKAGE.parent)))
        long_functions += [f"{path.relative_to(PACKAGE.parent)}:{n.name}" for n in ast.walk(ast.parse(text))
                           if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and _body_lines(n) > 80]
    assert (long_modules, long_functions) == ([], [])


def test_the_docs_map_names_every_package():
    """docs/architecture.md, the one-page map, shows every package of fotogeo and every tool package."""
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    packages = [p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()]
    packages += [p.name for p in (PACKAGE / "tools").iterdir() if (p / "__init__.py").exists()]
    assert [p for p in packages if f"{p}/" not in text] == []
