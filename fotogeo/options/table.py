"""The option mechanism: :class:`Option` (one keyword argument of a tool, as the command line and QGIS
show it), :class:`Table` (the ordered options of one tool) and their checks. The declarations — every
tool's table and the choice lists — are in :mod:`fotogeo.options`, which re-exports these names.

Standard library only (like :mod:`fotogeo.options`): the QGIS plugin reads it when it loads.
"""
from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass, replace

from ..errors import InputError


#: ``kind`` of an option: the Python value, the click type and the QGIS parameter it becomes
KINDS = {"int": "int / Integer number", "float": "float / Double number", "bool": "flag / Boolean",
         "str": "text / String", "choice": "one of choices / Enum", "choices": "comma list / multiple Enum",
         "ints": "comma list of int / String", "crs": "CRS text / CRS", "file": "path / File",
         "folder": "path of a folder / File (folder)", "path": "path of a file or a folder / File",
         "raster": "path / raster layer", "raster_out": "path of a raster to write / raster destination"}


@dataclass(frozen=True)
class Option:
    """One keyword argument of a tool, as the command line and QGIS show it (see the module docstring)."""

    name: str
    kind: str
    default: object = None
    label: str = ""  # QGIS parameter description
    help: str | None = None  # command-line help
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False  # the minimum itself is not valid (QGIS allows it only as ``automatic``)
    choices: tuple = ()
    advanced: bool = False
    automatic: float | None = None  # QGIS number standing for None
    none_choice: str | None = None  # QGIS enum entry standing for None, listed first
    file_filter: str = ""
    flag: str | None = None  # command-line flag [--name-with-dashes]
    param: str | None = None  # QGIS parameter name [NAME]
    repeat: bool = False  # kind "str": the flag may be repeated; the values are joined with ";" (QGIS: one text)
    #: the (bool) option this one acts with: its ``default`` applies only then; the tool's argument defaults to None
    #: (not given), and a value given without that option is refused (:func:`check_needs`), never ignored
    needs: str | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"option {self.name}: kind {self.kind!r} is not one of {', '.join(KINDS)}")

    @property
    def cli_flag(self) -> str:
        return self.flag or "--" + self.name.replace("_", "-")

    @property
    def qgis_name(self) -> str:
        return self.param or self.name.upper()

    @property
    def nullable(self) -> bool:
        return self.default is None

    @property
    def qgis_choices(self) -> tuple:
        """The entries of the QGIS enum: ``none_choice`` first when there is one."""
        return ((self.none_choice,) if self.none_choice else ()) + tuple(self.choices)

    def range_text(self) -> str:
        lo = "" if self.minimum is None else f"{'>' if self.exclusive_minimum else '>='} {self.minimum}"
        hi = "" if self.maximum is None else f"<= {self.maximum}"
        return " and ".join(t for t in (lo, hi) if t)

    def check(self, value) -> None:
        """Raise :class:`InputError` naming the option unless ``value`` has its kind, range and choices."""
        if value is None:
            if self.nullable or self.needs:  # a ``needs`` option not given: its default applies with the other
                return
            raise InputError(f"{self.name} needs a value (default {self.default!r})", option=self.name)
        if self.kind == "choice":
            if value not in self.choices:
                raise InputError(f"{self.name} {value!r} unknown; choose one of {', '.join(self.choices)}",
                                 option=self.name)
        elif self.kind == "bool":
            if value not in (True, False):
                raise InputError(f"{self.name} must be True or False; got {value!r}", option=self.name)
        elif self.kind in ("int", "float"):
            whole = self.kind == "int"
            if isinstance(value, bool) or not isinstance(value, numbers.Integral if whole else numbers.Real):
                raise InputError(f"{self.name} must be {'a whole number' if whole else 'a number'}; got {value!r}",
                                 option=self.name)
            below = self.minimum is not None and not (value > self.minimum if self.exclusive_minimum
                                                      else value >= self.minimum)
            above = self.maximum is not None and not value <= self.maximum
            if below or above or value != value:  # value != value: NaN
                raise InputError(f"{self.name} must be {self.range_text() or 'a number'}; got {value!r}",
                                 option=self.name)
            if not math.isfinite(value):  # ±inf: never a valid setting
                raise InputError(f"{self.name} must be a finite number; got {value!r}", option=self.name)
        elif self.kind == "str" and self.choices:  # a word of the choices or a number in range ("auto" or 20)
            if value in self.choices:
                return
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise InputError(f"{self.name} must be {' or '.join(map(repr, self.choices))} or a number "
                                 f"{self.range_text()}; got {value!r}", option=self.name) from None
            replace(self, kind="float", choices=(), default=0).check(number)
        elif self.kind in ("ints", "choices"):
            items = (value,) if isinstance(value, (str, bytes, numbers.Number)) else tuple(value)
            if not items:
                raise InputError(f"{self.name} needs at least one value", option=self.name)
            for item in items:  # each item as an "int" or a "choice" option of the same name and range
                replace(self, kind="int" if self.kind == "ints" else "choice", default=0).check(item)


def check_needs(values: dict, options) -> None:
    """Refuse an option of ``options`` given (not None in ``values``) while the option it ``needs`` is off: it
    would be ignored (``dsm --fill-max-distance`` without ``--fill`` was). The error names both (``also``), so the
    command line says both flags and QGIS both labels.

    >>> check_needs({"md": 2.0, "fill": False}, [Option("fill", "bool", False), Option("md", "float", 4.0,
    ...                                                                              needs="fill")])
    Traceback (most recent call last):
    fotogeo.errors.InputError: md 2.0 acts only with fill=True (alone it would be ignored): give both, or leave it out
    """
    for o in options:
        if o.needs and values.get(o.name) is not None and not values.get(o.needs):
            raise InputError(f"{o.name} {values[o.name]!r} acts only with {o.needs}=True (alone it would be ignored): "
                             f"give both, or leave it out", option=o.name, also=(o.needs,))


class Table(dict):
    """The options of one tool, by name, in the order the command line and QGIS list them.

    ``groups`` gathers several options into one keyword argument of the tool: a dict
    ``{key: option name}`` becomes a dict, a tuple of option names a tuple (e.g. the field
    names ``col_field``, ``row_field`` → ``approx_fields=("col", "row")``).
    """

    def __init__(self, *options: Option, groups: dict | None = None):
        super().__init__((o.name, o) for o in options)
        if len(self) != len(options):
            raise ValueError("an option table names an option twice")
        self.groups = dict(groups or {})

    def __add__(self, other: Table) -> Table:
        return Table(*self.values(), *other.values(), groups={**self.groups, **other.groups})

    def only(self, *names: str, **changes) -> Table:
        """The options ``names`` of this table (``changes``: ``{name: {field: value}}``)."""
        return Table(*(replace(self[n], **changes.get(n, {})) for n in names))

    def arguments(self, values: dict) -> dict:
        """``values`` (by option name) as the tool's keyword arguments: the groups gathered."""
        out = dict(values)
        for key, spec in self.groups.items():
            out[key] = ({k: out.pop(n) for k, n in spec.items()} if isinstance(spec, dict)
                        else tuple(out.pop(n) for n in spec))
        return out


def field_options(*names: str) -> tuple[Option, ...]:
    """``<name>_field`` options: the attribute names a point table is read with (advanced)."""
    return tuple(Option(f"{n}_field", "str", n, label=f"Field: {n}", advanced=True) for n in names)


_FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*")


def in_labels(message: str, *tables: Table, extra: dict | None = None) -> str:
    """``message`` in the words of a QGIS user: each command-line flag of an option of ``tables``
    (``--ratio``) becomes its parameter label in quotes, and a message that opens with an option's
    name (``ratio must be ...``, :meth:`Option.check`) opens with its label. ``extra`` maps further
    flags (the algorithm's own inputs, e.g. ``--reference``) to labels. Unknown flags stay as they are.

    >>> t = Table(Option("ratio", "float", 0.8, "Ratio test"), Option("dst_crs", "crs", "auto", "Output CRS",
    ...                                                               flag="--crs"))
    >>> in_labels("try a looser --ratio (0.9) or give --crs; --other stays", t)
    'try a looser “Ratio test” (0.9) or give “Output CRS”; --other stays'
    >>> in_labels("ratio must be <= 1.0; got 2", t)
    '“Ratio test” must be <= 1.0; got 2'

    A switch's negative flag (``--no-…``) is its box unticked:

    >>> in_labels("or keep it with --no-style", Table(Option("style", "bool", True, "Write a style")))
    'or keep it with “Write a style” unticked'
    """
    words = {o.cli_flag: o.label for t in tables for o in t.values() if o.label}
    switches = {"--no-" + o.cli_flag[2:]: o.label for t in tables for o in t.values() if o.label and o.kind == "bool"}
    words.update(extra or {})

    def said(m):
        flag = m.group(0)
        return f"“{words[flag]}”" if flag in words else f"“{switches[flag]}” unticked" if flag in switches else flag
    text = _FLAG.sub(said, str(message))
    for t in tables:
        for o in t.values():
            if o.label and re.match(rf"{re.escape(o.name)} (must|needs|['\"])", text):
                return f"“{o.label}”" + text[len(o.name):]
    return text
