"""Every tool option, declared once: the command line and the QGIS parameters are generated from here
(the mechanism, :class:`Option` and :class:`Table`, is in :mod:`fotogeo.options.table`; the shared
choice lists and options in :mod:`.shared`; each capability's tables in its own module: :mod:`.register`,
:mod:`.orient`, :mod:`.triangulate`, :mod:`.coreg`, :mod:`.interior`, :mod:`.products`, :mod:`.dsm`). The modules of the
package import :mod:`.table` and :mod:`.shared` (and a sibling's table they extend), never this aggregator.

An :class:`Option` is one keyword argument of a tool (``fotogeo/tools/<tool>.py``): its name,
kind, default, valid range or choices, the command-line help and flag, the QGIS parameter
label and name, and whether QGIS shows it under *Advanced*. A :class:`Table` is the ordered
set of options of one tool. From a table,

- ``fotogeo.cli.common.options_from(table)`` makes the click options of the ``fotogeo``
  command (flag ``--name-with-dashes``, default shown in ``--help``);
- ``processing_provider/algorithms/base.py`` adds the QGIS Processing parameters
  (``NAME`` in upper case) and reads them back into the tool's keyword arguments;
- :class:`RegisterOptions` (the registration settings) is a frozen dataclass built from
  :data:`REGISTER`, whose ``validate()`` checks types, ranges and choices against the table.

Conventions of the QGIS side, where a number or an enum cannot be empty: an option whose
default is ``None`` is an optional parameter (empty = ``None``), unless it has an
``automatic`` value — the number standing for ``None`` ("0 = automatic") — or a
``none_choice`` — the enum entry, listed first, standing for ``None`` ("default").

An option that acts only with a bool option (``needs``, e.g. ``fill_max_distance`` with ``fill``) is passed as None
when not given — the command line's default is None (``--help`` shows "4.0 with --fill"); QGIS passes None while
the other is off, whatever its parameter holds (the dialog keeps every parameter's last-used value, so a value there
is no choice made for the run; a value other than the default is named in the log as not used) — and the tool
boundary refuses it given alone, naming both (:func:`~fotogeo.options.table.check_needs`); the tool applies the
table's default when the other is on.

The choice lists (:data:`DETECTORS`, :data:`CONTRASTS`, :data:`RESAMPLINGS`,
:data:`PLANAR_MODELS`, :data:`TERRAIN_MODELS`, :data:`ORIENTATION_MODELS`, ...) live in
:mod:`.shared` and the array and tool modules import them, so there is one list of each. The package
imports the standard library only: the QGIS plugin reads it when it loads, before it knows
whether numpy and the other dependencies are installed.
"""
from __future__ import annotations

from .coreg import COREG  # noqa: F401
from .dsm import DSM  # noqa: F401
from .interior import INTERIOR  # noqa: F401
from .orient import (COMPARE, COMPARE_SETS, GCP, LAYER_TO_POINTS, ORIENT, POINTS_TO_LAYER, RPC_BIAS,  # noqa: F401
                     TARGETS, TRANSFER)
from .products import MOSAIC, ORTHO  # noqa: F401
from .register import (DEMO, FUSE, MATCH, REGISTER, REGISTER_BATCH, REGISTER_TERRAIN,  # noqa: F401
                       RegisterOptions)
from .shared import *  # noqa: F401,F403
from .table import KINDS, Option, Table, check_needs, field_options, in_labels  # noqa: F401
from .triangulate import TRIANGULATE  # noqa: F401


#: every tool's table, in the order :func:`find_option` searches them
_TABLES = (REGISTER, REGISTER_TERRAIN, MATCH, FUSE, DEMO, GCP, ORIENT, COMPARE, TRANSFER, TARGETS, RPC_BIAS,
           POINTS_TO_LAYER, LAYER_TO_POINTS, TRIANGULATE, REGISTER_BATCH, COREG, ORTHO, MOSAIC, INTERIOR, DSM)


def flags_of(name: str, tables=()) -> str | None:
    """The flag naming the option ``name`` in a message: its option's in the first of ``tables`` that has it, else in
    every tool's (:func:`find_option`); None if none.

    >>> flags_of("half_window"), flags_of("nope")
    ('--half-window', None)
    """
    found = next((t[name] for t in tables if name in t), None) or find_option(name)
    return found.cli_flag if found is not None else None


def find_option(name: str) -> Option | None:
    """The first option declared as ``name`` in the tools' tables (for a message's flag or label), or None.

    >>> find_option("half_window").cli_flag, find_option("nope")
    ('--half-window', None)
    """
    for table in _TABLES:
        if name in table:
            return table[name]
    return None
