"""What the sub-commands share: options generated from the option table, a console progress bar,
error reporting and exit codes."""
from __future__ import annotations

import contextlib
import functools
import re
import signal
import sys
import threading
import warnings

import click

from ..errors import (Cancelled, FotogeoError, FotogeoWarning, InputNote, OutputError, in_callers_words,
                      warning_line)
from ..options import Option, Table, flags_of
from . import conventions
from .conventions import EXIT_FAILED, EXIT_USAGE, quiet_option  # noqa: F401 (the commands' -q)

#: exit code of a FotogeoError about an option's value (a usage error, as click's own): one ``Error: ...`` line
EXIT_ERROR = EXIT_USAGE
#: exit code of a cancel (the progress callback said stop) or Ctrl-C: 128 + SIGINT, the shell's code for an interrupted job
EXIT_CANCELLED = 130
#: exit code after SIGTERM (``kill``): 128 + SIGTERM, what a shell reports for a terminated job
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """Raised in the main thread when the process receives SIGTERM.

    A :class:`KeyboardInterrupt` (not an ``Exception``), so library code that catches
    ``Exception`` does not swallow it and it unwinds like Ctrl-C: every
    :class:`~fotogeo.io.raster.AtomicOutputs` on the way removes its temporary files.
    """


def _raise_terminated(signum, frame):
    raise Terminated(f"terminated by signal {signal.Signals(signum).name}")


@contextlib.contextmanager
def terminate_as_exception():
    """While inside, SIGTERM raises :class:`Terminated` (main thread only; restored on exit)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def warnings_as_lines(recorded: list | None = None):
    """While inside, each warning (fotogeo's or a library's) is one ``Warning: <message>`` line
    on stderr — no file name, line number or source line — and a repeated message is shown once;
    library notes that mean nothing to a user are translated or silenced (:func:`~fotogeo.errors.warning_line`).
    With ``-q`` (:data:`conventions.SETTINGS`) nothing is shown; every distinct line is still appended to
    ``recorded`` (the ``warnings`` of the ``--json`` document)."""
    shown = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = warning_line(message, category)  # translated or silenced (fotogeo.errors)
        if text is None or text in shown:
            return
        shown.add(text)
        label = "Note" if isinstance(category, type) and issubclass(category, InputNote) else "Warning"
        if recorded is not None:
            recorded.append(f"{label}: {text}")
        if not conventions.SETTINGS.quiet:
            click.echo(f"{label}: {text}", err=True)

    with warnings.catch_warnings():
        # fotogeo's own warnings are the run's output, not a library's notes: shown whatever filters the
        # interpreter was started with (``-W ignore``, ``PYTHONWARNINGS``); a tool's own narrower filters,
        # set inside, still come first
        warnings.simplefilter("always", FotogeoWarning)
        warnings.showwarning = show
        yield


def warn(text: str) -> None:
    """A warning a command prints from its tool's report (e.g. ``rep["warnings"]``): through the one
    mechanism, :func:`warnings_as_lines` — one ``Warning:`` line on stderr, silenced by ``-q``, kept in
    ``--json``'s ``warnings``."""
    warnings.warn(text, FotogeoWarning, stacklevel=2)


#: switches every command that writes has, outside the option table
_SWITCHES = {"overwrite": "--overwrite"}


def flag_of(name: str | None) -> str | None:
    """The command-line flag of the option ``name`` (``half_window`` → ``--half-window``,
    :func:`fotogeo.options.flags_of`), None if none."""
    return (flags_of(name) or _SWITCHES.get(name)) if name else None


def _in_flags(e) -> str:
    """The message of the error ``e`` with the options it names (``option``, ``also``) called by their flags."""
    text = str(e)
    for name in (e.option, *getattr(e, "also", ())):
        text = in_callers_words(text, name, flag_of(name))
    return text


_CLICK_TYPES = {"int": int, "float": float, "str": str, "crs": str}


_NUMBER = re.compile(r"\d+(?:\.\d+)?(?:e[+-]?\d+)?")


class ConsoleProgress:
    """A progress callback on stderr (silent when ``quiet``): on a terminal one updating line (``\\r``); into a
    log (not a terminal) a plain line per new step or 10 %. The percentage shown never goes back: nested
    stages report their own fractions, which are not always in step with the whole."""

    def __init__(self, quiet: bool = False, width: int = 30, stream=None):
        self.quiet, self.width, self.last = quiet or conventions.SETTINGS.quiet, width, ""
        self.stream = stream or sys.stderr
        self.top, self.logged = 0.0, (None, -1)
        # -v: a plain line per step, as into a log, instead of the updating bar
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)()) and not conventions.SETTINGS.verbose

    def __call__(self, fraction: float, message: str) -> bool:
        if self.quiet:
            return True
        self.top = max(self.top, min(max(float(fraction), 0.0), 1.0))
        if not self.tty:
            return self._plain(message)
        filled = int(round(self.width * self.top))
        line = f"\r[{'#' * filled}{'.' * (self.width - filled)}] {self.top * 100:5.1f}% {message[:50]:<50}"
        if line != self.last:
            self.stream.write(line)
            self.stream.flush()
            self.last = line
        return True

    def _plain(self, message: str) -> bool:
        """A line when the message changes — counts apart ("iteration 7, cost 4305.2" is the message of
        "iteration 6, …": 60 iterations were 60 lines) — or a new 10 % step is reached."""
        step, kind = int(self.top * 10), _NUMBER.sub("#", message)
        if (kind, step) != self.logged and (kind != self.logged[0] or step > self.logged[1]):
            self.stream.write(f"{self.top * 100:5.1f}% {message}\n")
            self.stream.flush()
            self.logged = (kind, step)
        return True

    def close(self):
        if not self.quiet and self.last and self.tty:
            self.stream.write("\n")
            self.stream.flush()


def run_tool(func):
    """Decorator for command bodies: a fotogeo error becomes one line on stderr and an exit code
    (:mod:`fotogeo.cli.conventions`); with ``--json`` the command's return value is printed as JSON.

    - :class:`~fotogeo.errors.Cancelled` (the progress callback returned False): one line
      ``Cancelled: <message>`` and exit code 130 (:data:`EXIT_CANCELLED`, 128 + SIGINT, what a
      shell reports for an interrupted job); the tool has removed what it had started writing;
    - Ctrl-C (SIGINT): ``Cancelled: interrupted`` and exit code 130; SIGTERM: ``Cancelled:
      terminated by signal SIGTERM`` and exit code 143 (:data:`EXIT_TERMINATED`, 128 +
      SIGTERM). Both unwind as exceptions, so no temporary output is left behind;
    - a :class:`~fotogeo.errors.FotogeoError` about an option's value (it names the flag): ``Error: <message>``
      and exit code 2 (:data:`EXIT_USAGE`), as click's own usage errors — but an output that exists
      (:class:`~fotogeo.errors.OutputError` naming ``--overwrite``) is the file system's state: exit code 1;
    - any other :class:`~fotogeo.errors.FotogeoError` (the run failed): ``Error: <message>`` and exit code 1
      (:data:`EXIT_FAILED`), without a traceback.
    """
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        as_json = bool(kwargs.pop("json_output", False)) or conventions.SETTINGS.json
        ctx = click.get_current_context(silent=True)
        name = ctx.info_name if ctx is not None else func.__name__
        stdout = sys.stdout

        recorded = []

        def print_json(doc: dict):
            conventions.print_json({"command": name} | doc | ({"warnings": recorded} if recorded else {}), stdout)

        def stop(code: int, line: str):
            click.echo(line, err=True)  # the final error: shown even with -q
            if as_json:
                print_json({"exit_code": code, "error": line})
            sys.exit(code)

        try:  # a sub-command's -q is the group's -q (conventions.quieted): one rule for every line
            with terminate_as_exception(), conventions.quieted(bool(kwargs.get("quiet"))), \
                    warnings_as_lines(recorded), \
                    (contextlib.redirect_stdout(sys.stderr) if as_json else contextlib.nullcontext()):
                result = func(*args, **kwargs)
        except Terminated as e:
            stop(EXIT_TERMINATED, f"Cancelled: {e}; no output was written")
        except KeyboardInterrupt:
            stop(EXIT_CANCELLED, "Cancelled: interrupted (Ctrl-C); no output was written")
        except Cancelled as e:
            stop(EXIT_CANCELLED, f"Cancelled: {e}")
        except FotogeoError as e:
            # an output that exists names --overwrite but is the file system's state, not a bad value: exit 1
            stop(EXIT_USAGE if e.option and not isinstance(e, OutputError) else EXIT_FAILED,
                 f"Error: {_in_flags(e)}")
        if as_json:
            print_json({"exit_code": 0, "result": result})
        return result
    return wrapper


def _comma_list(option: Option):
    """click callback: ``"a,b"`` → ``("a", "b")`` (ints for kind ``ints``), checked against the option."""
    def convert(ctx, param, text):
        if text is None:
            return None
        items = tuple(t.strip() for t in text.split(","))
        if "" in items and any(items):  # "poly1,,affine" or a trailing comma: never drop a name silently
            raise click.BadParameter(f"an empty entry in {text!r}; separate the entries by single commas, "
                                     f"e.g. {','.join(t for t in items if t)}")
        items = tuple(t for t in items if t)
        if option.kind == "ints":
            try:
                items = tuple(int(t) for t in items)
            except ValueError:
                raise click.BadParameter(f"whole numbers separated by commas, e.g. 40,20,10; got {text!r}") from None
            if not items or (option.minimum is not None and min(items) < option.minimum):
                raise click.BadParameter(f"at least one number, each >= {option.minimum}; got {text!r}")
        else:
            unknown = [t for t in items if t not in option.choices]
            if unknown or not items:
                raise click.BadParameter(f"{', '.join(unknown) or 'nothing'} unknown; choose from "
                                         f"{', '.join(option.choices)}")
        return items
    return convert


def click_option(option: Option):
    """The click option of one table entry: flag, type, default (shown in ``--help``), help."""
    kw = dict(help=option.help, show_default=True)
    decls = [option.cli_flag, option.name]
    if option.kind == "bool":
        if option.default:
            decls[0] = f"{option.cli_flag}/--no-{option.cli_flag[2:]}"
            kw["default"] = True
        else:
            kw.update(is_flag=True, default=False, show_default=False)
    elif option.kind == "choice":
        kw.update(type=click.Choice(option.choices), default=option.default)
    elif option.kind in ("choices", "ints"):
        kw.update(default=None if option.default is None else ",".join(map(str, option.default)),
                  callback=_comma_list(option))
    elif option.repeat:
        kw.update(multiple=True, default=None, show_default=False,
                  callback=lambda ctx, param, values: ";".join(values or ()) or None)
    elif option.kind in ("file", "raster", "raster_out"):
        kw.update(type=click.Path(dir_okay=False), default=option.default)
    elif option.kind == "folder":
        kw.update(type=click.Path(file_okay=False), default=option.default)
    elif option.kind == "path":  # a file or a folder (a COLMAP model's folder): the tool tells which it reads
        kw.update(type=click.Path(), default=option.default)
    else:
        kw.update(type=_CLICK_TYPES[option.kind], default=option.default)
    if option.needs:  # not given: None, so that the tool can refuse it given alone; the default shown with the other
        kw.update(default=None, show_default=f"{option.default} with --{option.needs.replace('_', '-')}")
    return click.option(*decls, **kw)


def options_from(*tables: Table):
    """Decorator adding the click options of ``tables``, in table order, to a command."""
    def decorate(f):
        for option in reversed([o for t in tables for o in t.values()]):
            f = click_option(option)(f)
        return f
    return decorate


def tool_arguments(kw: dict, *tables: Table) -> dict:
    """Pop the values of ``tables``' options from ``kw``; return them as the tool's keyword arguments."""
    out = {}
    for table in tables:
        out.update(table.arguments({name: kw.pop(name) for name in table}))
    return out


def skipped_line(rep: dict) -> str | None:
    """The summary line of the GCPs a tool skipped (its report's ``skipped``: ``{id, col, row, reason}``,
    :func:`fotogeo.io.gcps.inside_image`), or None: printed even with ``--quiet``, which hides the warning."""
    skipped = rep.get("skipped") or []
    if not skipped:
        return None
    return (f"skipped ({skipped[0]['reason']}): "
            + ", ".join(f"{s['id']} (col {s['col']:.1f}, row {s['row']:.1f})" for s in skipped))
