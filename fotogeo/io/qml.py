"""A QGIS layer style (``.qml``) written beside a surface model, so that QGIS draws it as its heights.

QGIS picks a raster's default renderer from its band count: a GeoTIFF of more than one band is drawn as a
multiband colour composite of bands 1, 2, 3, whatever the bands' colour interpretation (GDAL's ``Gray`` /
``Undefined``, ``PHOTOMETRIC=MINISBLACK``) says. When it opens a file-based layer it first loads, as the layer's
default style, the file ``<folder>/<name>.qml`` beside ``<folder>/<name>.<ext>`` (``QgsMapLayer.styleURI``). A DSM's
style therefore lives in ``<name>.qml``, written with the DSM (:func:`dsm_style_path`, :func:`write_dsm_style`).

The style is the one of the QGIS plugin's ``styles/dsm.qml``: band 1 alone in a single-band pseudocolour
renderer, a hypsometric ramp (green, yellow, brown, white) interpolated between :data:`RAMP` stops, a legend in
metres. A loaded style keeps the range written in it (QGIS does not recompute it on load), so the range is the
heights' 2 … 98 % quantiles (the min/max origin stated, a cumulative cut, is what QGIS's "Apply" recomputes).

The file QGIS loads is also the one its "Save as Default" writes: a ``<name>.qml`` there may be a user's own style.
fotogeo's carries :data:`MARKER`, an XML comment, which QGIS does not write back (it serialises the layer's style, not
the file it loaded): a style without it is replaced only with ``overwrite`` (:func:`check_style`) — never in
silence by the QGIS plugin, which keeps it (:func:`users_style`) — and a run may write none (``qgis_style`` off).
fotogeo wrote its style without the marker before it had one: such a file is recognised by its content, the text
:func:`dsm_style` writes for the range it holds without the marker line (:func:`_earlier_fotogeo`), so that it is
replaced as a marked one is; any edit (a colour, a stop, a range label, QGIS saving it back) makes it a user's.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import FotogeoWarning, OutputError

#: the ramp's stops: (fraction of the range, colour "r,g,b")
RAMP = ((0.0, "26,152,80"), (0.25, "145,207,96"), (0.5, "254,224,139"), (0.75, "166,97,26"), (1.0, "245,245,245"))
#: the cumulative cut of the range (lower, upper fraction of the heights)
CUT = (0.02, 0.98)

#: the comment that marks a style as fotogeo's own (module docstring)
MARKER = "<!-- written by fotogeo with its DSM -->"
#: how far into a style :data:`MARKER` is looked for (it follows the DOCTYPE line)
_HEAD = 512
#: the most of a style read to recognise fotogeo's earlier, unmarked one (it has about 3 kB)
_MOST = 16384

_TEMPLATE = """<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
{marker}
<qgis version="3.22.16-Białowieża" styleCategories="Symbology">
  <pipe>
    <rasterrenderer type="singlebandpseudocolor" band="1" alphaBand="-1" opacity="1" nodataColor=""
                    classificationMin="{lo!r}" classificationMax="{hi!r}">
      <minMaxOrigin>
        <limits>CumulativeCut</limits>
        <extent>WholeRaster</extent>
        <statAccuracy>Estimated</statAccuracy>
        <cumulativeCutLower>{cut[0]}</cumulativeCutLower>
        <cumulativeCutUpper>{cut[1]}</cumulativeCutUpper>
        <stdDevFactor>2</stdDevFactor>
      </minMaxOrigin>
      <rastershader>
        <colorrampshader colorRampType="INTERPOLATED" classificationMode="1" clip="0" labelPrecision="1"
                         minimumValue="{lo!r}" maximumValue="{hi!r}">
          <colorramp type="gradient" name="[source]">
            <Option type="Map">
              <Option name="color1" type="QString" value="{first},255"/>
              <Option name="color2" type="QString" value="{last},255"/>
              <Option name="discrete" type="QString" value="0"/>
              <Option name="rampType" type="QString" value="gradient"/>
              <Option name="stops" type="QString" value="{stops}"/>
            </Option>
          </colorramp>
{items}
          <rampLegendSettings useContinuousLegend="1" minimumLabel="" maximumLabel="" prefix="" suffix=" m"
                              direction="0" orientation="2">
            <numericFormat id="basic">
              <Option type="Map">
                <Option name="decimals" type="int" value="1"/>
                <Option name="show_trailing_zeros" type="bool" value="false"/>
              </Option>
            </numericFormat>
          </rampLegendSettings>
        </colorrampshader>
      </rastershader>
    </rasterrenderer>
    <brightnesscontrast gamma="1" contrast="0" brightness="0"/>
    <huesaturation grayscaleMode="0" saturation="0" colorizeOn="0"/>
    <rasterresampler maxOversampling="2"/>
    <resamplingStage>resamplingFilter</resamplingStage>
  </pipe>
  <blendMode>0</blendMode>
</qgis>
"""


def dsm_style_path(dsm) -> Path:
    """The style QGIS loads with the raster ``dsm`` (``<folder>/<name>.qml``; module docstring)."""
    return Path(dsm).with_suffix(".qml")


def check_styles_no_input(dsm, inputs, role: str = "DSM") -> None:
    """Refuse a DSM ``dsm`` whose style (:func:`dsm_style_path`) QGIS would also load for one of the ``inputs``
    (None: not given): an input ``<folder>/<name>.<ext>`` beside ``-o <folder>/<name>.tiff`` would open restyled
    as heights."""
    style = dsm_style_path(dsm).resolve()
    for p in (p for p in inputs if p is not None):
        if Path(p).with_suffix(".qml").resolve() == style:
            raise OutputError(f"{role} {str(dsm)!r}: its QGIS style {style.name!r} would also restyle the input "
                              f"{str(p)!r} (QGIS loads <name>.qml with any layer of that name); give the {role} "
                              f"another name")


def users_style(dsm) -> Path | None:
    """The style beside the raster ``dsm`` (:func:`dsm_style_path`) when it is a file fotogeo did not write (no
    :data:`MARKER` near its start: a user's, or one QGIS saved as the layer's default), else None."""
    style = dsm_style_path(dsm)
    if not style.is_file():
        return None
    try:
        with open(style, encoding="utf-8", errors="replace", newline="") as f:
            text = f.read(_MOST + 1)
    except OSError:
        return style  # unreadable: not known to be fotogeo's
    return None if MARKER in text[:_HEAD] or _earlier_fotogeo(text) else style


def _earlier_fotogeo(text: str) -> bool:
    """Whether ``text`` is the style an earlier fotogeo wrote, before :data:`MARKER` (module docstring): exactly
    :func:`dsm_style` of the range in its ``classificationMin`` / ``classificationMax`` without the marker line
    (floats written with ``repr`` read back to the same text). Its line endings are compared as LF: a copy
    saved on Windows (CRLF) or with old Mac CR endings is the same style."""
    import re
    if len(text) > _MOST:
        return False
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    found = [re.search(rf'{key}="([^"]*)"', text) for key in ("classificationMin", "classificationMax")]
    try:
        lo, hi = (float(m.group(1)) for m in found)
    except (AttributeError, ValueError):
        return False
    return hi > lo and any(text == dsm_style(lo, hi, exact).replace(MARKER + "\n", "", 1) for exact in (True, False))


def warn_earlier_style(dsm, role: str = "DSM") -> None:
    """With no style written (``qgis_style`` off): warn when a style fotogeo wrote for an earlier run lies beside
    ``dsm`` — QGIS would draw the new raster with that run's height range."""
    import warnings
    style = dsm_style_path(dsm)
    if style.is_file() and users_style(dsm) is None:
        warnings.warn(f"{str(style)!r}, the QGIS style fotogeo wrote for an earlier {role} of that name, is left "
                      f"beside it (no style written this run): QGIS draws the new {role} with that run's height "
                      f"range; delete it, or write a new one (without --no-qgis-style)", FotogeoWarning, stacklevel=3)


def check_style(dsm, overwrite: bool, role: str = "DSM") -> None:
    """Before any work, before the outputs' own checks (whose refusal of the DSM would have the user pass
    ``overwrite`` and lose the style in silence): refuse to replace a style fotogeo did not write
    (:func:`users_style`) without ``overwrite``, naming the way to keep it (``qgis_style=False``). A style of
    fotogeo's that exists is the run's output like the DSM (:func:`fotogeo.io.output_checks.check_outputs`)."""
    mine = users_style(dsm)
    if mine is not None and not overwrite:
        raise OutputError(f"QGIS style of the {role} {str(mine)!r} exists; pass overwrite=True to replace it (fotogeo "
                          f"did not write it: a style of yours?), or keep it and write none with qgis_style=False",
                          option="overwrite", also=("qgis_style",))


def dsm_style(lo: float, hi: float, exact_ends: bool = True) -> str:
    """The QML text drawing band 1 over ``lo`` … ``hi`` metres (``hi`` > ``lo``; module docstring). The ramp's first
    and last items are ``lo`` and ``hi`` themselves (``lo + 1·(hi − lo)`` can differ from ``hi`` in its last bit);
    ``exact_ends=False``: as fotogeo wrote them before session 28, the ends interpolated too."""
    lo, hi = float(lo), float(hi)
    hi = hi if hi > lo else lo + max(abs(lo), 1.0) * 1e-3  # a flat surface: a range QGIS can interpolate over
    inner = ":".join(f"{f};{c},255" for f, c in RAMP[1:-1])

    def at(f):
        return lo if exact_ends and f == 0 else hi if exact_ends and f == 1 else lo + f * (hi - lo)
    items = "\n".join(
        f'          <item value="{at(f)!r}" label="{at(f):.1f}" '
        f'color="#{"".join(f"{int(v):02x}" for v in c.split(","))}" alpha="255"/>' for f, c in RAMP)
    return _TEMPLATE.format(marker=MARKER, lo=lo, hi=hi, cut=CUT, first=RAMP[0][1], last=RAMP[-1][1], stops=inner,
                            items=items)


def write_dsm_style(path, lo: float, hi: float) -> None:
    """Write :func:`dsm_style` to ``path`` (an :class:`~fotogeo.io.raster.AtomicOutputs` temporary file)."""
    with open(path, "w", encoding="utf-8") as f:
        f.write(dsm_style(lo, hi))
