"""The QGIS plugin (processing_provider/) is written so that one source runs on Qt5 (QGIS 3.x) and Qt6 (QGIS 4).

The rules follow QGIS's own PyQt5 -> PyQt6 migration script (scripts/pyqt5_to_pyqt6 in the QGIS sources), in the
form that also works on PyQt5 5.15 (QGIS 3.22):

R1  enum members are spelt with their enum's scope: ``Qt.ItemDataRole.UserRole``, not ``Qt.UserRole``;
    ``QAbstractItemView.SelectionBehavior.SelectRows``, not ``QAbstractItemView.SelectRows``. PyQt6 has no
    unscoped members. Applies to every class imported from qgis.PyQt (or QtCore/QtGui/QtWidgets modules).
R2  ``exec()`` and ``print()``, not ``exec_()`` / ``print_()`` (removed in PyQt6; ``exec()`` exists in PyQt5 5.15).
R3  Qt comes from ``qgis.PyQt``, never from ``PyQt5``/``PyQt6`` directly.
R4  ``QVariant.Int`` etc. stay as they are (QGIS shims them on Qt6); ``QVariant.Type.Int`` does not exist there.
R5  removed in Qt6: ``QRegExp``, ``qApp``, ``QDesktopWidget`` / ``.desktop()``, ``activated[str]``,
    ``QFontMetrics.width``, ``Qt.MidButton``, compiled resources (``resources_rc``).
R6  a dialog's result is not read from the instance (``dlg.Accepted``): compare ``exec()`` with 0/1 or spell
    ``QDialog.DialogCode.Accepted``.
R7  (where PyQt is importable) every scoped name used exists in the installed PyQt and equals the unscoped member,
    so the sweep did not change a value on Qt5.

``pyqtSignal`` / ``QtCore.pyqtSignal`` are fine in both. The scan is pure ``ast`` (R1-R6 run without Qt); the rules
are checked against known-bad snippets so they can fail.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PLUGIN = Path(__file__).resolve().parents[1] / "processing_provider"
QT_MODULES = {"QtCore", "QtGui", "QtWidgets"}
QT_SOURCES = {"qgis.PyQt.QtCore", "qgis.PyQt.QtGui", "qgis.PyQt.QtWidgets"}
REMOVED_NAMES = {"QRegExp": "QRegularExpression", "qApp": "QApplication.instance()",
                 "QDesktopWidget": "QScreen (QApplication.screens())"}
RENAMED = {("Qt", "MidButton"): "Qt.MouseButton.MiddleButton",
           ("Qt", "TextColorRole"): "Qt.ItemDataRole.ForegroundRole",
           ("Qt", "BackgroundColorRole"): "Qt.ItemDataRole.BackgroundRole"}


def _qt_names(tree: ast.Module) -> set[str]:
    """Names bound to Qt classes in this module: ``from qgis.PyQt.QtX import A, B``."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module in QT_SOURCES:
            names.update(a.asname or a.name for a in node.names)
    return names


def _chain(node: ast.AST) -> list[str] | None:
    """``a.b.c`` -> ["a", "b", "c"]; None when the chain does not start at a plain name."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return [node.id] + parts[::-1]


def violations(source: str, name: str = "<snippet>") -> list[str]:
    """Every Qt5-only idiom in *source* as ``name:line: rule: text``."""
    tree = ast.parse(source)
    qt = _qt_names(tree) - {"QVariant", "pyqtSignal", "pyqtSlot", "QT_VERSION_STR", "PYQT_VERSION_STR"}
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    out = []

    def bad(node, rule, text):
        out.append(f"{name}:{node.lineno}: {rule}: {text}")

    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in ("PyQt5", "PyQt6"):
            bad(node, "R3", f"import from {node.module}: use qgis.PyQt")
        if isinstance(node, ast.Import) and any(a.name.split(".")[0] in ("PyQt5", "PyQt6") for a in node.names):
            bad(node, "R3", "import PyQt5/PyQt6: use qgis.PyQt")
        if isinstance(node, ast.ImportFrom):
            for a in node.names:
                if a.name in REMOVED_NAMES or a.name == "resources_rc":
                    bad(node, "R5", f"{a.name} is removed in Qt6")
        if isinstance(node, ast.Name) and node.id in REMOVED_NAMES and isinstance(node.ctx, ast.Load):
            bad(node, "R5", f"{node.id}: use {REMOVED_NAMES[node.id]}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in ("exec_", "print_"):
                bad(node, "R2", f"{node.func.attr}(): use {node.func.attr[:-1]}()")
            if node.func.attr == "desktop" and not node.args:
                bad(node, "R5", "desktop() is removed in Qt6")
            if node.func.attr == "width" and isinstance(node.func.value, ast.Call) and (
                    getattr(node.func.value.func, "attr", None) == "fontMetrics"
                    or getattr(node.func.value.func, "id", None) in ("QFontMetrics", "QFontMetricsF")):
                bad(node, "R5", "QFontMetrics.width(): use horizontalAdvance()")
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Attribute) \
                and node.value.attr == "activated" and getattr(node.slice, "id", None) == "str":
            bad(node, "R5", "activated[str] is removed in Qt6: use textActivated")
        if not isinstance(node, ast.Attribute) or isinstance(parents.get(node), ast.Attribute):
            continue  # only whole chains: Qt.ItemDataRole.UserRole is judged once, from its outermost node
        chain = _chain(node)
        if chain is None:
            continue
        via_module = chain[0] in QT_MODULES and len(chain) > 1
        if via_module:
            chain = chain[1:]  # QtCore.Qt.UserRole is Qt.UserRole
        if chain[:2] == ["QVariant", "Type"]:
            bad(node, "R4", ".".join(chain) + ": QVariant.Type.X does not exist on Qt6, write QVariant.X")
        if tuple(chain[:2]) in RENAMED:
            bad(node, "R5", f"{'.'.join(chain[:2])}: use {RENAMED[tuple(chain[:2])]}")
        if chain[-1] in ("Accepted", "Rejected") and chain[:2] != ["QDialog", "DialogCode"]:
            bad(node, "R6", ".".join(chain) + ": use QDialog.DialogCode." + chain[-1])
        called = isinstance(parents.get(node), ast.Call) and parents[node].func is node
        if len(chain) == 2 and (chain[0] in qt or via_module) and chain[0] != "QVariant" and not called and _is_member(chain[0], chain[1]):
            bad(node, "R1", ".".join(chain) + ": unscoped enum member, write " + f"{chain[0]}.<Enum>.{chain[1]}")
    return out


def _is_member(cls: str, attr: str) -> bool:
    """An enum member name as Qt spells them: CamelCase (``SelectRows``), ``Key_Delete``/``Format_RGBA8888``, or a
    lower-case ``Qt.GlobalColor`` (``darkGray``). Nested classes and enum types are used with a further attribute
    or a call, which the caller already excludes; static methods are lower-case and called."""
    if cls == "Qt":
        return True  # the Qt namespace holds enums and functions only; functions are called
    return attr[:1].isupper()


def plugin_files() -> list[Path]:
    files = sorted(PLUGIN.rglob("*.py"))
    assert len(files) > 20, f"processing_provider/ looks empty at {PLUGIN}"
    return files


def test_plugin_has_no_qt5_only_idiom():
    found = [v for f in plugin_files() for v in violations(f.read_text(), str(f.relative_to(PLUGIN.parent)))]
    assert not found, "Qt5-only idioms (rules in tests/test_qt6_idioms.py):\n" + "\n".join(found)


BAD = {
    "R1": "from qgis.PyQt.QtCore import Qt\nx = Qt.UserRole\n",
    "R1 class": "from qgis.PyQt.QtWidgets import QAbstractItemView\nv.setSelectionBehavior(QAbstractItemView.SelectRows)\n",
    "R1 module": "from qgis.PyQt import QtCore\nx = QtCore.Qt.AlignRight\n",
    "R1 colour": "from qgis.PyQt.QtCore import Qt\nc.setCanvasColor(Qt.darkGray)\n",
    "R2": "d.exec_()\n",
    "R3": "from PyQt5.QtCore import Qt\n",
    "R4": "from qgis.PyQt.QtCore import QVariant\nt = QVariant.Type.Int\n",
    "R5": "from qgis.PyQt.QtCore import QRegExp\n",
    "R5 renamed": "from qgis.PyQt.QtCore import Qt\nb = Qt.MidButton\n",
    "R6": "ok = d.exec() == d.Accepted\n",
}
GOOD = """
from qgis.PyQt.QtCore import Qt, QVariant, pyqtSignal
from qgis.PyQt.QtWidgets import QAbstractItemView, QDialog, QFileDialog
from qgis.PyQt import QtCore
role = Qt.ItemDataRole.UserRole + 1
v.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
t = QVariant.Double
s = QtCore.pyqtSignal(int)
p = QFileDialog.getOpenFileName(None, "x")
ok = d.exec() == QDialog.DialogCode.Accepted
Qt.mightBeRichText("x")
"""


@pytest.mark.parametrize("rule", sorted(BAD))
def test_rules_catch_each_idiom(rule):
    found = violations(BAD[rule])
    assert any(f": {rule.split()[0]}: " in v for v in found), (rule, found)


def test_rules_accept_the_qt6_spelling():
    assert violations(GOOD) == []


def test_scoped_names_exist_in_installed_pyqt():
    """R7: on this PyQt (5.15 with QGIS 3.22 here) each ``Class.Enum.Member`` resolves and equals ``Class.Member``."""
    pyqt = pytest.importorskip("qgis.PyQt.QtCore", reason="qgis.PyQt not importable: R7 needs a QGIS Python")
    from qgis.PyQt import QtGui, QtWidgets
    modules = (pyqt, QtGui, QtWidgets)
    checked = 0
    for f in plugin_files():
        tree = ast.parse(f.read_text())
        qt = _qt_names(tree)
        for node in ast.walk(tree):
            chain = _chain(node) if isinstance(node, ast.Attribute) else None
            if not chain or len(chain) != 3 or chain[0] not in qt or chain[0] == "QVariant":
                continue
            cls = next(getattr(m, chain[0]) for m in modules if hasattr(m, chain[0]))
            scope = getattr(cls, chain[1], None)
            assert scope is not None and hasattr(scope, chain[2]), f"{f.name}:{node.lineno}: {'.'.join(chain)}"
            if isinstance(scope, type) and hasattr(cls, chain[2]):
                assert getattr(scope, chain[2]) == getattr(cls, chain[2]), f"{f.name}:{node.lineno}"
            checked += 1
    assert checked > 30
