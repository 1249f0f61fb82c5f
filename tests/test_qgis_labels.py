"""Parameter labels a GIS user reads at a glance, in a dialog that needs no horizontal scrolling.

Measured in the desktop QGIS 3.22 (Xvfb, the default font), the triangulate dialog at 900 px wide leaves its
parameter panel a viewport of 588 px; a label takes at most 6.9 px per character, and QGIS appends
" [optional]" (11 characters) to optional parameters: a label of :data:`MAX_LABEL` characters plus that
suffix is ≤ 560 px and fits. What a shorter label leaves out is in the parameter's help, QGIS's tooltip
(:func:`processing_provider.algorithms.base.with_help`: the option's command-line help in the dialog's words).
"""
from __future__ import annotations

from qgis_env import need_qgis, qgis_app  # noqa: F401 - the session fixture

need_qgis()

MAX_LABEL = 70


def _algorithms():
    from qgis.core import QgsApplication
    provider = QgsApplication.processingRegistry().providerById("fotogeo")
    assert provider is not None and len(provider.algorithms()) >= 15
    return provider.algorithms()


def test_every_parameter_label_fits_a_900_px_dialog(qgis_app):  # noqa: F811
    long = [f"{alg.name()}:{d.name()} ({len(d.description())}): {d.description()}"
            for alg in _algorithms() for d in alg.parameterDefinitions() if len(d.description()) > MAX_LABEL]
    assert not long, "\n".join(long)


def test_option_parameters_carry_their_help_in_the_dialogs_words(qgis_app):  # noqa: F811
    """Every option with a command-line help has it as the parameter's help (the tooltip), command-line flags
    of the algorithm's options replaced by their labels."""
    from fotogeo.options import TRIANGULATE
    checked = 0
    for alg in _algorithms():
        for table in alg.OPTIONS:
            for option in table.values():
                definition = alg.parameterDefinition(option.qgis_name)
                if option.help and definition is not None:
                    assert definition.help(), f"{alg.name()}:{option.qgis_name} has no help"
                    assert definition.help() in definition.toolTip()
                    checked += 1
    assert checked > 100
    triangulate = next(a for a in _algorithms() if a.name() == "triangulate")
    mosaic = triangulate.parameterDefinition("MOSAIC").help()
    assert "--orthorectify" not in mosaic and f"“{TRIANGULATE['orthorectify'].label}”" in mosaic
    # the detail a shortened label left out is in the help
    assert "attitude from the reference" in triangulate.parameterDefinition("EO").help()
    assert "seamlines in mosaic.gpkg" in mosaic
