"""``fotogeo ortho IMAGE... [--camera C.yaml --eo EO | --rpc] --dem DEM -o OUT`` — orthophotos of oriented images."""
from __future__ import annotations

import click

from ..options.products import ORTHO
from .common import ConsoleProgress, options_from, quiet_option, run_tool, tool_arguments


@click.command("ortho")
@click.argument("images", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(),
              help="The orthophoto (one image), or a folder for <name>_ortho.tif of each image.")
@options_from(ORTHO)
@click.option("--overwrite", is_flag=True)
@quiet_option
@run_tool
def command(images, output, overwrite, quiet, **kw):
    """Orthorectify IMAGES whose orientation is known onto a DEM.

    Frame cameras: --camera and --eo (fotogeo's 'name X Y Z omega phi kappa' lines, triangulate's outputs,
    OpenSfM/ODM, COLMAP or orthority files). Satellite images: --rpc (the RPC in the GeoTIFF). With
    --occlusion and a DSM as --dem, ground hidden from the camera becomes nodata instead of a double image.
    One image through its fitted orient model: --model (orient's JSON report).
    --uncertainty writes <orthophoto>_sigma.tif (predicted planimetric sigma, m; triangulate's outputs only),
    --view-bands <orthophoto>_view.tif (off-nadir angle, distance).
    """
    from ..io.warp_source import keep_freed_memory
    from ..tools.ortho.tool import ortho
    keep_freed_memory()  # the windows' temporaries are reused instead of faulted in again
    bar = ConsoleProgress(quiet)
    try:
        rep = ortho(list(images), output, overwrite=overwrite, progress=bar, **tool_arguments(kw, ORTHO))
    finally:
        bar.close()
    click.echo(f"map CRS {rep['crs']}: {rep['crs_rule']}; heights: {'; '.join(rep['notes'])}")
    for name, r in rep["images"].items():
        cover = "" if r["dem_coverage"] >= 0.999 else f", DEM covers {100 * r['dem_coverage']:.0f} % of it"
        click.echo(f"{name}: {r['width']}x{r['height']} px at {r['resolution']:.4g} m, "
                   f"{r['valid_pixels']} valid{cover} -> {r['path']}")
        if "sigma" in r:
            click.echo(f"  predicted planimetric sigma {r['sigma']['min_m']:.3g} to {r['sigma']['max_m']:.3g} m "
                       f"(DEM sigma {rep['dem_sigma_m']:.3g} m, {rep['dem_sigma_rule']}) -> {r['sigma']['path']}")
        if "view" in r:
            click.echo(f"  off-nadir angle and distance -> {r['view']['path']}")
    return rep
