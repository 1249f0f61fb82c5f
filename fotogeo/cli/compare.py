"""``fotogeo compare-models IMAGE GCPS --table T.csv`` — the paper's Table 1 for your GCPs."""
from __future__ import annotations

import click

from .common import ConsoleProgress, run_tool
from .orient import fields_of, gcp_options


@click.command("compare-models")
@click.argument("image", type=click.Path(dir_okay=False))
@click.argument("gcps", type=click.Path(dir_okay=False))
@click.option("--models", help="Comma-separated model names [all that the GCPs allow].")
@click.option("--counts", default="40,20,15,10,6", show_default=True, help="Control-point counts.")
@click.option("--spreads", default="homogeneous,heterogeneous", show_default=True)
@click.option("--trials", type=int, default=5, show_default=True, help="Seeded trials per cell (median reported).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--table", type=click.Path(dir_okay=False), help="CSV output.")
@click.option("--markdown", type=click.Path(dir_okay=False), help="Markdown output.")
@gcp_options
@click.option("-q", "--quiet", is_flag=True)
@run_tool
def command(image, gcps, models, counts, spreads, quiet, **kw):
    """Compare orientation models at several GCP counts, homogeneous and clustered, at check points."""
    from ..tools.compare import compare_models, markdown_table
    fields = fields_of(kw)
    bar = ConsoleProgress(quiet)
    try:
        rows = compare_models(image, gcps, models=models.split(",") if models else None,
                              counts=tuple(int(c) for c in counts.split(",")), spreads=tuple(spreads.split(",")),
                              fields=fields, progress=bar, **kw)
    finally:
        bar.close()
    click.echo(markdown_table(rows))
