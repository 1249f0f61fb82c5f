"""``fotogeo compare-models IMAGE GCPS --table T.csv`` — the paper's Table 1 for your GCPs."""
from __future__ import annotations

import click

from ..options import COMPARE, GCP
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("compare-models")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("gcps", type=click.Path(dir_okay=False))
@options_from(COMPARE)
@click.option("--table", type=click.Path(dir_okay=False), help="CSV output.")
@click.option("--markdown", type=click.Path(dir_okay=False), help="Markdown output (the paper's Table 1 layout).")
@click.option("--html", type=click.Path(dir_okay=False), help="HTML output (the paper's Table 1 layout).")
@click.option("--plots", type=click.Path(file_okay=False), help="Folder for error-vector plots per model and layout.")
@options_from(GCP)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(image, gcps, quiet, **kw):
    """Compare orientation models on control/check sets (random or the file's roles) at check points:
    the paper's Table 1 (Öztürk, Karşlı & Dihkan) for your GCPs."""
    from ..tools.orient.compare import compare_models, markdown_table
    bar = ConsoleProgress(quiet)
    try:
        rows = compare_models(image, gcps, progress=bar, **tool_arguments(kw, COMPARE, GCP), **kw)
    finally:
        bar.close()
    click.echo(markdown_table(rows))
    from ..tools.orient.compare_rank import ranking
    click.echo(ranking(rows)[1])
    return rows
