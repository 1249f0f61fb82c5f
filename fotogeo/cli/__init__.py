"""The ``fotogeo`` command line: one thin sub-command per capability.

Each sub-command lives in its own module of this package and calls one tool function; its
options are generated from the tool's table in :mod:`fotogeo.options`
(:func:`fotogeo.cli.common.options_from`). Errors derived from
:class:`fotogeo.errors.FotogeoError` are printed as one clear line without a traceback:
exit code 2, or 130 for a cancel (:func:`fotogeo.cli.common.run_tool`).
"""
from __future__ import annotations

import importlib

import click

from .. import __version__

#: modules of this package that each define ``command`` (a click command, or a list of them).
COMMAND_MODULES = ("register", "match", "fuse", "demo", "orient", "compare", "transfer", "targets", "points",
                   "rpc_bias", "register_batch", "triangulate", "coreg", "interior",
                   "ortho", "mosaic", "dsm")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="fotogeo")
def main():
    """fotogeo: aerial and satellite images to map-accurate data."""


for _name in COMMAND_MODULES:
    _cmd = importlib.import_module(f"{__name__}.{_name}").command
    for _c in (_cmd if isinstance(_cmd, list) else [_cmd]):
        main.add_command(_c)
