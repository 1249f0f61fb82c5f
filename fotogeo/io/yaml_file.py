"""YAML files fotogeo reads (camera, orthority interior parameters, calibration reports), through PyYAML.

:func:`read_yaml_mapping` loads one YAML document with ``yaml.SafeLoader`` (no object tags) and returns the
mapping with the line number of each top-level key, for messages that point at the line. Everything YAML allows
is read: flow lists ``[900, 700]`` and block lists (``- 900`` lines), a leading ``---``, comments, quoted keys
such as ``'DJI FC6310: 8.8mm':``.

Scalars follow YAML 1.2's core schema rather than PyYAML's YAML 1.1 default, because camera files are written
by hand and by other programs: ``1e-5`` is a number (1.1 reads it as text), ``0700`` is 700 (1.1: octal 448),
only ``true``/``false`` are booleans (1.1 also takes yes/no/on/off, which are camera ids and file names here).
Keys are text: ``1: [-106.0, 106.0]`` has the key ``"1"``.

Any problem is one :class:`~fotogeo.errors.InputError` starting with ``where`` and naming the line.
"""
from __future__ import annotations

import re

import yaml

from ..errors import InputError, one_line

#: lists inside lists deeper than this are refused (the files hold flat lists such as ``[w, h]``)
MAX_LIST_DEPTH = 2

_BOOL, _INT, _FLOAT = "tag:yaml.org,2002:bool", "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"


class _CoreLoader(yaml.SafeLoader):
    """SafeLoader with YAML 1.2 core-schema booleans, integers and floats (module docstring)."""


_CoreLoader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in (_BOOL, _INT, _FLOAT)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_CoreLoader.add_implicit_resolver(_BOOL, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))
_CoreLoader.add_implicit_resolver(_INT, re.compile(r"^[-+]?[0-9]+$"), list("-+0123456789"))
_CoreLoader.add_implicit_resolver(
    _FLOAT, re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
                       r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"), list("-+0123456789."))
_CoreLoader.add_constructor(_INT, lambda loader, node: int(loader.construct_scalar(node), 10))


def yaml_key(name: str) -> str:
    """``name`` as a YAML mapping key: as it is when YAML reads it back as the same text, else double-quoted
    (``'DJI FC6310: 8.8mm'`` -> ``"DJI FC6310: 8.8mm"``)."""
    text = str(name)
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_ .()/-]*", text) and text == text.strip() and \
            text.lower() not in ("true", "false", "null", "~") and ": " not in text:
        return text
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _flow_depth(line: str) -> int:
    """The deepest ``[`` nesting on one line, outside quotes and comments."""
    depth = deepest = 0
    quote = None
    for ch in line:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#":
            break
        elif ch == "[":
            depth += 1
            deepest = max(deepest, depth)
        elif ch == "]":
            depth -= 1
    return deepest


def _check_flat(text: str, where: str) -> None:
    """Refuse deeply nested flow lists before parsing (PyYAML would recurse once per level)."""
    for lineno, line in enumerate(text.splitlines(), 1):
        if "[" in line and (depth := _flow_depth(line)) > MAX_LIST_DEPTH:
            key = line.split(":", 1)[0].strip() if ":" in line else "value"
            raise InputError(one_line(f"{where}line {lineno}: {key}: a list nested {depth} deep; write a flat "
                                      f"list such as [900, 700]"))


def _list_depth(value) -> int:
    if isinstance(value, list):
        return 1 + max((_list_depth(v) for v in value), default=0)
    if isinstance(value, dict):
        return max((_list_depth(v) for v in value.values()), default=0)
    return 0


def _text_keys(value):
    """Mapping keys as text at every level (``1:`` -> ``"1"``), as the files' ids are names."""
    if isinstance(value, dict):
        return {str(k): _text_keys(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_text_keys(v) for v in value]
    return value


def _key_text(node) -> str:
    """A top-level key as :func:`_text_keys` spells it, from its node (without constructing the document again)."""
    value = node.value if isinstance(node, yaml.ScalarNode) else str(node.value)
    if node.tag == _INT:
        return str(int(value, 10))
    if node.tag == _FLOAT:
        return str(float(value.lower().replace(".inf", "inf").replace(".nan", "nan")))
    if node.tag == _BOOL:
        return str(value.lower() == "true")
    return value


def _yaml_problem(exc: yaml.YAMLError, where: str) -> InputError:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    at = f"line {mark.line + 1}: " if mark is not None else ""
    problem = getattr(exc, "problem", None) or str(exc)
    if isinstance(exc, yaml.reader.ReaderError):
        return InputError(one_line(f"{where}holds a character YAML does not allow ({exc.reason}, "
                                   f"{exc.character!r}); save it as plain UTF-8 text"))
    if "another document" in problem:
        return InputError(one_line(f"{where}{at}holds a second YAML document (a second '---'); keep one per file"))
    hint = "indent with spaces, not tabs" if "\\t" in problem or "\t" in problem else \
        "each line is 'key: value', nested keys indented under theirs, lists as [a, b] or '- a' lines"
    return InputError(one_line(f"{where}{at}not valid YAML ({problem}); {hint}"))


def read_yaml_mapping(text: str, where: str = "") -> tuple[dict, dict]:
    """``(data, lines)``: the file's one YAML document as a dict and the line number of each top-level key.

    An empty file is ``({}, {})``. ``where`` (the file, e.g. ``"camera 'io.yaml', "``) starts every message.
    """
    _check_flat(text, where)
    loader = None
    try:
        loader = _CoreLoader(text)  # the reader refuses control characters here
        node = loader.get_single_node()
        data = loader.construct_document(node) if node is not None else None
    except yaml.YAMLError as exc:
        raise _yaml_problem(exc, where) from None
    except RecursionError:
        raise InputError(one_line(f"{where}nested too deeply to be a camera or option file")) from None
    finally:
        if loader is not None:
            loader.dispose()
    if data is None:
        return {}, {}
    if not isinstance(data, dict):
        raise InputError(one_line(f"{where}line {node.start_mark.line + 1}: expected 'key: value' lines at the top "
                                  f"level, got a {'list' if isinstance(data, list) else 'single value'}"))
    lines: dict = {}
    for key_node, _ in node.value:
        key = _key_text(key_node)
        if key in lines:
            raise InputError(one_line(f"{where}line {key_node.start_mark.line + 1}: {key!r} is given twice "
                                      f"(first on line {lines[key]}); keep one"))
        lines[key] = key_node.start_mark.line + 1
    data = _text_keys(data)
    for key, value in data.items():
        if _list_depth(value) > MAX_LIST_DEPTH:
            raise InputError(one_line(f"{where}line {lines[key]}: {key}: lists nested {_list_depth(value)} deep; "
                                      f"write flat lists such as [900, 700]"))
    return data, lines
