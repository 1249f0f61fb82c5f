"""The ``fotogeo`` command line: one thin sub-command per capability.

Each sub-command lives in its own module of this package and calls one tool function; its
options are generated from the tool's table in :mod:`fotogeo.options`
(:func:`fotogeo.cli.common.options_from`). Errors derived from
:class:`fotogeo.errors.FotogeoError` are printed as one clear line without a traceback
(:func:`fotogeo.cli.common.run_tool`). Exit codes, ``-v``/``-q`` logging, ``--json`` and deprecated
option spellings: :mod:`fotogeo.cli.conventions`.

A run imports only the module of the sub-command it runs (:data:`COMMANDS`; ``--help`` and ``main.commands``
load them all) and reads the version only for ``--version``: a short ``ortho`` run's CPU time is mostly its
imports.
"""
from __future__ import annotations

import atexit
import gc
import importlib

import click

from . import conventions

#: sub-command name -> the module of this package that defines it (``command``: a click command, or a list of
#: them); ``tests/test_cli_lazy.py`` checks that this is what the modules define.
COMMANDS = {"register": "register", "match": "match", "fuse": "fuse", "demo": "demo", "orient": "orient",
            "compare-models": "compare", "transfer-points": "transfer", "measure-targets": "targets",
            "points-to-layer": "points", "layer-to-points": "points", "rpc-bias": "rpc_bias",
            "register-batch": "register_batch", "triangulate": "triangulate", "coreg": "coreg",
            "interior": "interior", "ortho": "ortho", "mosaic": "mosaic", "dsm": "dsm"}
#: the modules, in the order the commands were registered
COMMAND_MODULES = tuple(dict.fromkeys(COMMANDS.values()))


class _Group(click.Group):
    """The ``fotogeo`` group: every sub-command also takes ``--json``; deprecated option spellings are
    rewritten (with a warning) before the sub-command parses them; a sub-command's module is imported when the
    command is first looked up (:data:`COMMANDS`), all of them when ``commands`` is read."""

    @property
    def commands(self):
        for module in COMMAND_MODULES:
            self._load(module)
        return self._loaded

    @commands.setter
    def commands(self, value):  # click.Group.__init__ sets it
        self._loaded, self._modules = dict(value or {}), set()

    def _load(self, module: str) -> None:
        if module not in self._modules:
            self._modules.add(module)
            cmd = importlib.import_module(f"{__name__}.{module}").command
            for c in (cmd if isinstance(cmd, list) else [cmd]):
                self.add_command(c)

    def add_command(self, cmd, name=None):
        if isinstance(cmd, click.Command) and not any(p.name == "json_output" for p in cmd.params):
            cmd.params.append(click.Option(["--json", "json_output"], is_flag=True,
                                           help="Print the run's summary as JSON on stdout (human lines go to stderr)."))
        self._loaded[name or cmd.name] = cmd

    def get_command(self, ctx, cmd_name):
        if cmd_name in COMMANDS:
            self._load(COMMANDS[cmd_name])
        return self._loaded.get(cmd_name)

    def list_commands(self, ctx):
        return sorted(set(COMMANDS) | set(self._loaded))

    def resolve_command(self, ctx, args):
        name, cmd, rest = super().resolve_command(ctx, args)
        return name, cmd, conventions.rewrite_deprecated(cmd.name if cmd else name, rest)


def _print_version(ctx, _param, value):
    """``--version``: click's ``version_option`` message, the version read only when asked for."""
    if value and not ctx.resilient_parsing:
        from .. import __version__
        click.echo(f"fotogeo, version {__version__}", color=ctx.color)
        ctx.exit()


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_print_version,
              help="Show the version and exit.")
@click.option("-v", "--verbose", count=True, help="Say more: -v each step, -vv debugging detail (logging).")
@conventions.quiet_option
@click.option("--json", "json_output", is_flag=True,
              help="Print the run's summary as JSON on stdout (human lines go to stderr).")
def main(verbose, quiet, json_output):
    """fotogeo: aerial and satellite images to map-accurate data.

    Exit codes: 0 done, 1 the run failed, 2 a usage error, 130 cancelled (Ctrl-C). Raster inputs may be
    GDAL virtual paths (/vsizip/, /vsicurl/, /vsis3/) or URLs.
    """
    from ..io.clocale import c_case_rules_for_process
    c_case_rules_for_process()  # GDAL's option names compared as in English under a Turkish or Azeri locale
    conventions.settings(verbose=verbose, quiet=quiet, json=json_output)
    conventions.setup_logging(verbose, quiet)
    # once, however many runs a process makes: at the process's exit what is left is frozen, so the interpreter's
    # last collections skip the imports' ~44k objects (0.09 -> 0.03 CPU s; docs/benchmarks/products.md)
    atexit.unregister(gc.freeze)
    atexit.register(gc.freeze)
