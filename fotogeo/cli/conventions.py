"""The command line's conventions (rasterio's ``rio`` as the model), shared by every sub-command.

- Exit codes: 0 done; 1 the run failed (an input cannot be read or used, images do not match, a model is
  refused, an output cannot be written); 2 a usage error (click's own — an unknown option, a missing
  argument — and a fotogeo error about an option's value, which names the flag); 130 cancelled or Ctrl-C
  (128 + SIGINT); 143 SIGTERM.
- ``fotogeo -v`` / ``-vv`` / ``-q`` on the group: :mod:`logging` levels. fotogeo's loggers (``fotogeo.*``) say
  more with ``-v`` (INFO: each step of the progress) and ``-vv`` (DEBUG, and the libraries' own INFO);
  ``-q`` (on the group or after any sub-command: one setting, :func:`quieted`) hides the progress bar and every
  ``Note:`` / ``Warning:`` line on stderr; it keeps the final ``Error:`` line and the run's summary on stdout.
  The warnings are not lost: ``--json`` lists them (``warnings``), and a tool's report file keeps those it
  records (orient's ``warnings``/``skipped``, interior's per-scan ``warnings``). A library's log record of
  WARNING or above (rasterio's GDAL notes, distributed's) is shown as one ``Warning:`` line through
  :func:`fotogeo.errors.warning_line`, like a Python warning: translated or silenced, never as the library's raw
  text with its logger's name.
- ``--json`` on the group or after any sub-command: the run's summary (what the tool returned) as one JSON
  document on stdout; the human lines go to stderr. On an error: ``{"error": ..., "exit_code": ...}``.
- Deprecated spellings of options (:data:`DEPRECATED`) keep working for one release with a warning (shown
  even with ``-q``: scripts, which run quiet, are where the old spellings live).
"""
from __future__ import annotations

import contextlib
import json
import logging
import re
import sys

import click

from ..errors import warning_line

EXIT_FAILED = 1
EXIT_USAGE = 2

#: what ``-q`` / ``--quiet`` does, in every command's ``--help``
QUIET_HELP = ("Quiet: no progress, notes or warnings on stderr (--json still lists the warnings); "
              "the summary and a final Error line stay.")
#: ``-q`` / ``--quiet`` on the group and after every sub-command: one setting (:func:`quieted`)
quiet_option = click.option("-q", "--quiet", is_flag=True, help=QUIET_HELP)

#: sub-command -> {old flag: new flag}: spellings unified across commands, accepted until the next release
DEPRECATED = {"register-batch": {"--outdir": "--output"},
              "coreg": {"--reference-band": "--reference-bands", "--target-band": "--target-bands"}}

#: libraries whose INFO/DEBUG records only ``-vv`` shows
LIBRARY_LOGGERS = ("rasterio", "fiona", "pyogrio", "distributed", "dask", "numexpr", "matplotlib", "PIL")


class _Settings:
    verbose = 0
    quiet = False
    json = False


SETTINGS = _Settings()


def settings(**changes) -> _Settings:
    """The group's settings (``-v``, ``-q``, ``--json``), updated by the group and read by the commands."""
    for k, v in changes.items():
        setattr(SETTINGS, k, v)
    return SETTINGS


class _OneLine(logging.Formatter):
    """WARNING and above as fotogeo's ``Warning:`` / ``Error:`` line (a library's text through
    :func:`~fotogeo.errors.warning_line`), INFO as its message, DEBUG with the logger's name."""

    def __init__(self):
        super().__init__()
        self.shown: set = set()

    def format(self, record):
        message = record.getMessage()
        if record.levelno >= logging.WARNING:
            own = record.name == "fotogeo" or record.name.startswith("fotogeo.")
            if not own:  # rasterio logs GDAL's CPL errors as "CPLE_AppDefined in <GDAL's text>"
                message = re.sub(r"^CPLE_\w+ in ", "GDAL: ", message.strip())
            text = " ".join(message.split()) if own else warning_line(message, UserWarning)
            return "" if text is None else f"{'Error' if record.levelno >= logging.ERROR else 'Warning'}: {text}"
        if record.levelno >= logging.INFO:
            return message
        return f"[{record.name}] {message}"


class _Handler(logging.StreamHandler):
    """Writes to the current ``sys.stderr`` (click's test runner swaps it) and drops empty or repeated lines."""

    def __init__(self):
        super().__init__()
        self.setFormatter(_OneLine())
        self.shown: set = set()

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass

    def emit(self, record):
        text = self.format(record)
        if not text or (record.levelno >= logging.WARNING and text in self.shown):
            return
        self.shown.add(text)
        try:
            sys.stderr.write(text + "\n")
            sys.stderr.flush()
        except Exception:  # noqa: BLE001 - logging must never break a run
            self.handleError(record)


def setup_logging(verbose: int = 0, quiet: bool = False) -> None:
    """One handler on the root logger; levels from ``-v``/``-q`` (module docstring)."""
    root = logging.getLogger()
    for h in [h for h in root.handlers if isinstance(h, _Handler)]:
        root.removeHandler(h)
    root.addHandler(_Handler())
    own = logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    root.setLevel(logging.DEBUG if verbose >= 2 else logging.WARNING)
    logging.getLogger("fotogeo").setLevel(own)
    for name in LIBRARY_LOGGERS:
        logging.getLogger(name).setLevel(logging.ERROR if quiet else
                                         (logging.DEBUG if verbose >= 2 else logging.WARNING))


@contextlib.contextmanager
def quieted(quiet: bool):
    """While inside, a sub-command's own ``-q`` acts as the group's: :data:`SETTINGS` ``.quiet`` and the log
    levels of :func:`setup_logging` (restored on exit: a process may make several runs)."""
    if not quiet or SETTINGS.quiet:
        yield
        return
    loggers = [logging.getLogger(n) for n in ("fotogeo", *LIBRARY_LOGGERS)]
    levels = [g.level for g in loggers]
    SETTINGS.quiet = True
    for g in loggers:
        g.setLevel(logging.ERROR)
    try:
        yield
    finally:
        SETTINGS.quiet = False
        for g, level in zip(loggers, levels):
            g.setLevel(level)


def rewrite_deprecated(command: str, args: list[str]) -> list[str]:
    """``args`` with each deprecated flag of ``command`` replaced by its new spelling, warning once per flag."""
    renames = DEPRECATED.get(command, {})
    out = []
    for a in args:
        flag, eq, value = a.partition("=")
        if flag in renames:
            click.echo(f"Warning: {flag} is deprecated and goes in the next release; use {renames[flag]}",
                       err=True)  # shown even with -q: the script's command line itself stops working
            a = renames[flag] + eq + value
        out.append(a)
    return out


def jsonable(value):
    """``value`` as JSON types: dicts and lists kept, result objects through their ``report`` or ``__dict__``,
    paths as text, numpy scalars and arrays as numbers and lists, non-finite numbers as null."""
    from ..io.report import _jsonable
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if hasattr(value, "to_dict") and callable(value.to_dict):
        return jsonable(value.to_dict())
    if hasattr(value, "__dataclass_fields__"):  # a result: its paths and report, not its model objects
        import numpy as np
        from pathlib import Path
        plain = (str, int, float, bool, type(None), Path, dict, list, tuple, np.generic, np.ndarray)
        return jsonable({k: getattr(value, k) for k in value.__dataclass_fields__
                         if isinstance(getattr(value, k), plain)})
    if isinstance(value, float) and value != value or value in (float("inf"), float("-inf")):
        return None
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    try:
        converted = _jsonable(value)
    except TypeError:
        return str(value)
    return jsonable(converted) if converted is not value else str(value)


def print_json(document: dict, stream=None) -> None:
    (stream or sys.stdout).write(json.dumps(jsonable(document), allow_nan=False) + "\n")
