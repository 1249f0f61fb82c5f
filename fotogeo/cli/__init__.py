"""The ``fotogeo`` command line: one thin sub-command per capability.

Each sub-command lives in its own module of this package and calls one tool function; its
options are generated from the tool's table in :mod:`fotogeo.options`
(:func:`fotogeo.cli.common.options_from`). Errors derived from
:class:`fotogeo.errors.FotogeoError` are printed as one clear line without a traceback
(:func:`fotogeo.cli.common.run_tool`). Exit codes, ``-v``/``-q`` logging, ``--json`` and deprecated
option spellings: :mod:`fotogeo.cli.conventions`.
"""
from __future__ import annotations

import importlib

import click

from .. import __version__
from . import conventions

#: modules of this package that each define ``command`` (a click command, or a list of them).
COMMAND_MODULES = ("register", "match", "fuse", "demo", "orient", "compare", "transfer", "targets", "points",
                   "rpc_bias", "register_batch", "triangulate", "coreg", "interior",
                   "ortho", "mosaic", "dsm")


class _Group(click.Group):
    """The ``fotogeo`` group: every sub-command also takes ``--json``; deprecated option spellings are
    rewritten (with a warning) before the sub-command parses them."""

    def add_command(self, cmd, name=None):
        if isinstance(cmd, click.Command) and not any(p.name == "json_output" for p in cmd.params):
            cmd.params.append(click.Option(["--json", "json_output"], is_flag=True,
                                           help="Print the run's summary as JSON on stdout (human lines go to stderr)."))
        super().add_command(cmd, name)

    def resolve_command(self, ctx, args):
        name, cmd, rest = super().resolve_command(ctx, args)
        return name, cmd, conventions.rewrite_deprecated(cmd.name if cmd else name, rest)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="fotogeo")
@click.option("-v", "--verbose", count=True, help="Say more: -v each step, -vv debugging detail (logging).")
@click.option("-q", "--quiet", is_flag=True, help="Errors only: no progress, no warnings.")
@click.option("--json", "json_output", is_flag=True,
              help="Print the run's summary as JSON on stdout (human lines go to stderr).")
def main(verbose, quiet, json_output):
    """fotogeo: aerial and satellite images to map-accurate data.

    Exit codes: 0 done, 1 the run failed, 2 a usage error, 130 cancelled (Ctrl-C). Raster inputs may be
    GDAL virtual paths (/vsizip/, /vsicurl/, /vsis3/) or URLs.
    """
    conventions.settings(verbose=verbose, quiet=quiet, json=json_output)
    conventions.setup_logging(verbose, quiet)


for _name in COMMAND_MODULES:
    _cmd = importlib.import_module(f"{__name__}.{_name}").command
    for _c in (_cmd if isinstance(_cmd, list) else [_cmd]):
        main.add_command(_c)
