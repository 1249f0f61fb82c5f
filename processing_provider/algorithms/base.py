"""What every fotogeo Processing algorithm shares.

- fotogeo's tools never run in QGIS's process: :meth:`FotogeoAlgorithm.run_tool` runs them in
  the plugin's runtime (``python -m fotogeo.worker``, see :mod:`processing_provider.runner` and
  :mod:`processing_provider.runtime` for why), which reports progress, warnings and the
  result as JSON; cancel stops the worker, whose atomic outputs clean up;
- every fotogeo error — a cancel included — becomes a :class:`QgsProcessingException`
  carrying the tool's own one-line message;
- :meth:`FotogeoAlgorithm.canExecute` is False, with the reason and the one command that fixes
  it, until the runtime works (the toolbox then refuses to open the algorithm);
- the tool options are parameters generated from the algorithm's option tables
  (:attr:`FotogeoAlgorithm.OPTIONS`, from :mod:`fotogeo.options`, see :func:`parameter`) and
  read back into the tool's keyword arguments (:meth:`FotogeoAlgorithm.option_arguments`).
"""
from __future__ import annotations

import os

from qgis.core import (
    QgsApplication,
    QgsProcessing,
    QgsCoordinateReferenceSystem,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingUtils,
    QgsProviderRegistry,
    QgsRasterLayer,
)
from qgis.PyQt.QtCore import QCoreApplication
from qgis.PyQt.QtGui import QIcon

# standard library only: the plugin loads without fotogeo's dependencies
from fotogeo.options import Option, Table, flags_of, in_labels
from fotogeo.errors import in_callers_words  # standard library only

from .. import runner
from ..side_files import no_side_files
from .widgets import plain_text

ICONS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "icons")
REFERENCES = {
    "dihkan": "Dihkan (2019): automatic registration of multi-epoch, multi-sensor aerial images to an "
              "orthophoto with PCA band fusion, SURF, RANSAC and a homography.",
    "surf": "Bay, H., Ess, A., Tuytelaars, T., Van Gool, L. (2008): Speeded-Up Robust Features (SURF). "
            "Computer Vision and Image Understanding 110(3), 346-359.",
    "sift": "Lowe, D. G. (2004): Distinctive image features from scale-invariant keypoints. IJCV 60(2), 91-110.",
    "ransac": "Fischler, M. A., Bolles, R. C. (1981): Random sample consensus. Comm. ACM 24(6), 381-395.",
}


def _is_file(value) -> bool:
    """Whether a parameter value is the path of an existing file (not a layer id, URI or layer object)."""
    return isinstance(value, str) and os.path.isfile(value)


def _all_files(value) -> bool:
    """Whether a multiple-layer value is a non-empty list of existing file paths (one path: a list of one)."""
    values = value if isinstance(value, (list, tuple)) else [value]
    return bool(values) and all(_is_file(v) for v in values)


class RasterFileParameter(QgsProcessingParameterRasterLayer):
    """A raster-layer parameter whose value, when it is the path of an existing file, is acceptable without
    loading it as a QGIS layer: ``qgis_process`` checks every value itself before the algorithm runs, and a
    layer that loads computes statistics (GDAL's PAM saves them beside the file) and, for a frame without a
    georeference (a drone JPEG, a scanned photo), makes GDAL print "ERROR 1: Unable to compute a
    transformation …" on the user's console. fotogeo's worker checks the file itself (:meth:`raster_path`)."""

    def checkValueIsAcceptable(self, value, context=None):  # noqa: N802 - QGIS API
        if _is_file(value):
            return True
        with no_side_files():
            return super().checkValueIsAcceptable(value, context)


class RasterFilesParameter(QgsProcessingParameterMultipleLayers):
    """A multiple-layer parameter of rasters whose value, a list of existing files, is acceptable without
    loading them (see :class:`RasterFileParameter`)."""

    def checkValueIsAcceptable(self, value, context=None):  # noqa: N802 - QGIS API
        if _all_files(value):
            return True
        with no_side_files():
            return super().checkValueIsAcceptable(value, context)


def layer_source_path(layer) -> str:
    """The file path of a GDAL raster layer (its source without the provider's options)."""
    return QgsProviderRegistry.instance().decodeUri("gdal", layer.source()).get("path") or layer.source()


def tr(text: str) -> str:
    return QCoreApplication.translate("fotogeo", text)


def crs_spec(crs: QgsCoordinateReferenceSystem) -> str:
    """'auto' for an empty CRS parameter, else an authority code or WKT pyproj understands."""
    if not crs.isValid():
        return "auto"
    if crs.authid().upper().startswith(("EPSG:", "ESRI:", "IAU")):
        return crs.authid()
    return crs.toWkt(QgsCoordinateReferenceSystem.WKT_PREFERRED)


def _number_parameter(option: Option, label: str):
    """A number option: default ``None`` → optional (empty = None) unless ``automatic`` stands for None."""
    Num = QgsProcessingParameterNumber
    bounds = {k: float(v) for k, v in (("minValue", option.minimum), ("maxValue", option.maximum)) if v is not None}
    empty_is_none = option.nullable and option.automatic is None
    default = option.automatic if option.nullable else option.default
    return Num(option.qgis_name, label, Num.Integer if option.kind == "int" else Num.Double, defaultValue=default,
               optional=empty_is_none, **bounds)


def parameter(option: Option) -> QgsProcessingParameterDefinition:
    """The QGIS Processing parameter of one option of :mod:`fotogeo.options` (see its docstring)."""
    name, label, kind = option.qgis_name, tr(option.label), option.kind
    if kind in ("int", "float"):
        p = _number_parameter(option, label)
    elif kind == "bool":
        p = QgsProcessingParameterBoolean(name, label, defaultValue=option.default)
    elif kind == "choice":
        p = QgsProcessingParameterEnum(name, label, options=list(option.qgis_choices),
                                       defaultValue=0 if option.nullable else option.qgis_choices.index(option.default))
    elif kind == "choices":
        p = QgsProcessingParameterEnum(
            name, label, options=list(option.qgis_choices), allowMultiple=True, optional=option.nullable,
            defaultValue=None if option.nullable else [option.qgis_choices.index(c) for c in option.default])
    elif kind == "ints":
        p = QgsProcessingParameterString(name, label, defaultValue=",".join(map(str, option.default)))
    elif kind == "str":
        p = QgsProcessingParameterString(name, label, defaultValue=option.default, optional=option.nullable)
    elif kind == "crs":
        p = QgsProcessingParameterCrs(name, label, optional=True)
    elif kind in ("file", "path"):  # QGIS picks a file; a COLMAP model is given by its images.txt/.bin
        p = QgsProcessingParameterFile(name, label, optional=True, fileFilter=option.file_filter)
    elif kind == "folder":
        p = QgsProcessingParameterFile(name, label, behavior=QgsProcessingParameterFile.Folder, optional=True)
    elif kind == "raster_out":
        p = QgsProcessingParameterRasterDestination(name, label, optional=True, createByDefault=False)
    else:  # raster
        p = RasterFileParameter(name, label, optional=True)
    if option.advanced:
        p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
    return p


def with_help(definition: QgsProcessingParameterDefinition, text: str) -> QgsProcessingParameterDefinition:
    """``definition`` with ``text`` as its help (QGIS shows it in the parameter's tooltip): where a label's
    detail goes, so that the label reads at a glance."""
    if text:
        definition.setHelp(tr(text))
    return definition


def _whole_numbers(option: Option, text: str) -> tuple:
    """The comma-separated whole numbers of an ``ints`` option, or a clear exception."""
    try:
        values = tuple(int(c) for c in text.replace(" ", "").split(",") if c)
    except ValueError:
        raise QgsProcessingException(f"{option.qgis_name} must be whole numbers separated by commas, e.g. "
                                     f"40,20,10; got {text!r}") from None
    if not values or (option.minimum is not None and min(values) < option.minimum):
        raise QgsProcessingException(f"{option.qgis_name} needs at least one whole number, each >= "
                                     f"{option.minimum}; got {text!r}")
    return values


class FotogeoAlgorithm(QgsProcessingAlgorithm):
    """Base class: names, help, lazy tool import, progress and error bridging."""

    #: stable lowercase algorithm id; display name (short: the toolbox shows ~25 characters); group (id, name)
    ALG_ID = ""
    DISPLAY = ""
    GROUP = ("", "")
    #: what the algorithm does in one line (the help's first line, where the short name is not enough)
    SUMMARY = ""
    HELP = ""
    #: ``icons/<ICON>.svg`` [the group id]: one icon per family of algorithms
    ICON = ""
    #: the option tables (:mod:`fotogeo.options`) whose options are parameters of this algorithm
    OPTIONS: tuple[Table, ...] = ()
    #: command-line flags of the algorithm's own inputs (not in :attr:`OPTIONS`) → their parameter labels
    WORDS: dict = {}

    def name(self):
        return self.ALG_ID

    def displayName(self):
        return tr(self.DISPLAY)

    def group(self):
        return tr(self.GROUP[1])

    def groupId(self):
        return self.GROUP[0]

    def shortHelpString(self):
        text = (f"<b>{tr(self.SUMMARY)}.</b>\n\n" if self.SUMMARY else "") + tr(self.HELP)
        ok, why = runner.runtime_status()
        if not ok:
            text += "\n\n<b>" + tr("Not runnable yet") + ":</b> " + why
        return plain_text(text) if QgsApplication.platform() == "qgis_process" else text  # it prints, not renders

    def canExecute(self):  # noqa: N802 - QGIS API
        """(False, what is missing and the fix) until fotogeo's runtime works."""
        ok, why = runner.runtime_status()
        return (True, "") if ok else (False, why)

    def svgIconPath(self):  # noqa: N802 - QGIS API
        path = os.path.join(ICONS, f"{self.ICON or self.GROUP[0]}.svg")
        return path if os.path.exists(path) else ""

    def icon(self):
        path = self.svgIconPath()
        return QIcon(path) if path else QgsApplication.getThemeIcon("/processingAlgorithm.svg")

    def createInstance(self):
        return type(self)()

    # -- checking the parameters ---------------------------------------------------------
    def checkParameterValues(self, parameters, context):
        """QGIS's check of every parameter; rasters given as existing file paths (one or a list) are not loaded
        as layers to be checked (:class:`RasterFileParameter`, :class:`RasterFilesParameter`); what is loaded
        loads without GDAL side files (:mod:`processing_provider.side_files`)."""
        for definition in self.parameterDefinitions():
            name = definition.name()
            with no_side_files():
                acceptable = definition.checkValueIsAcceptable(parameters.get(name), context)
            if not acceptable:
                if isinstance(definition, QgsProcessingParameterRasterLayer):
                    return False, self.invalidRasterError(parameters, name)
                return False, tr(f"Incorrect parameter value for {name}")
        return True, ""

    # -- running a tool ------------------------------------------------------------------
    def run_tool(self, tool: str, *args, feedback=None, **kwargs):
        """Run fotogeo's ``tool`` (``fotogeo.worker.TOOLS``) in the runtime; its result as JSON types.

        Paths and options go as JSON; progress, warnings and cancel travel with the feedback;
        a fotogeo error arrives as a :class:`QgsProcessingException` with the tool's message, an option
        it names called by its parameter's label (:meth:`option_label`).
        """
        for note in dict.fromkeys(self.__dict__.pop("_unused_notes", [])):  # options left unused (:meth:`_not_used`)
            if feedback is not None:
                feedback.pushWarning(note)
        return runner.run_tool(tool, *args, feedback=feedback, words=self.in_words, **kwargs)

    def in_words(self, message: str, option: str | None = None, also=()) -> str:
        """A tool's message as this dialog speaks: command-line flags → the parameter labels the user sees;
        ``option``, the option an error is about (``FotogeoError.option``), and ``also``, the further options it
        names (``FotogeoError.also``), by their labels too."""
        for name in (option, *also):
            # by its flag (fotogeo.options.flags_of), which in_labels turns into this dialog's labels
            message = in_callers_words(message, name, flags_of(name, self.OPTIONS))
        return in_labels(message, *self.OPTIONS, extra=self.WORDS)

    # -- parameters ----------------------------------------------------------------------
    def raster_path(self, parameters, name: str, context) -> str:
        """Local file path of a raster-layer parameter (a GDAL file), or a clear exception.

        A file path given as text (``qgis_process``, ``processing.run``, the dialog's file browser) is taken
        as it is, never loaded as a QGIS layer: a QGIS raster layer computes statistics when it loads, and
        GDAL saves them in an ``.aux.xml`` beside the file (fotogeo's worker reads the file itself)."""
        given = parameters.get(name)
        if _is_file(given):
            return given
        with no_side_files():
            layer = self.parameterAsRasterLayer(parameters, name, context)
        if layer is None or not isinstance(layer, QgsRasterLayer):
            raise QgsProcessingException(self.invalidRasterError(parameters, name))
        if layer.providerType() != "gdal":
            raise QgsProcessingException(
                f"{name}: layer {layer.name()!r} comes from the {layer.providerType()!r} provider, not from a "
                f"raster file; save it as a GeoTIFF (Export > Save As) and use that file")
        return layer_source_path(layer)

    def layer_paths(self, parameters, name: str, context) -> list:
        """File paths of a multiple-layer parameter: paths given as text are taken as they are (never
        loaded, see :meth:`raster_path`); layers of the project and URIs give their sources' paths."""
        given = parameters.get(name)
        if given in (None, "", []):
            return []
        if _all_files(given):
            return [str(v) for v in (given if isinstance(given, (list, tuple)) else [given])]
        with no_side_files():
            return [layer_source_path(layer) for layer in self.parameterAsLayerList(parameters, name, context)]

    def raster_output(self, parameters, name: str, context) -> str:
        """Path of a raster destination parameter; fotogeo writes GeoTIFF, so it must end in .tif/.tiff."""
        path = self.parameterAsOutputLayer(parameters, name, context)
        if not path.lower().endswith((".tif", ".tiff")):
            raise QgsProcessingException(f"{name}: fotogeo writes GeoTIFF; give a file name ending in .tif "
                                         f"(got {path!r})")
        return path

    def file_output_or_beside(self, parameters, name: str, context, main: str, suffix: str) -> str:
        """A file destination's path; left empty or temporary, ``main`` with ``suffix`` — beside the main
        output, as the command line does and as the label's "[beside the raster]" says."""
        given = parameters.get(name)
        sink = getattr(given, "sink", None)
        text = sink.staticValue() if sink is not None else given
        if text in (None, "", QgsProcessing.TEMPORARY_OUTPUT):
            return os.path.splitext(main)[0] + suffix
        return self.parameterAsFileOutput(parameters, name, context)

    def layer_stem(self, path: str, parameters, source: str, context) -> str:
        """The name a run's layers start with: the output file's stem, or — for a temporary output
        (``OUTPUT.tif`` in Processing's temporary folder) — the name of the ``source`` input layer."""
        temporary = os.path.abspath(path).startswith(os.path.abspath(QgsProcessingUtils.tempFolder()))
        if temporary and _is_file(parameters.get(source)):  # a path is not loaded (see raster_path)
            return os.path.splitext(os.path.basename(parameters[source]))[0]
        with no_side_files():
            layer = self.parameterAsLayer(parameters, source, context) if temporary else None
        return layer.name() if layer is not None else os.path.splitext(os.path.basename(path))[0]

    def add_options(self, table: Table):
        """Add the parameters of the options of ``table``, in table order; each with its option's help (the
        command-line help in the dialog's words, :meth:`in_words`) as the help QGIS shows in its tooltip — the
        detail a short label leaves out."""
        for option in table.values():
            self.addParameter(with_help(parameter(option), self.in_words(option.help or "")))

    def option_value(self, parameters, option: Option, context):
        """The value of ``option``'s parameter as the tool takes it (None for empty / automatic)."""
        name, kind = option.qgis_name, option.kind
        if kind in ("int", "float"):
            given = parameters.get(name)
            if option.nullable and option.automatic is None and (given is None or str(given).strip() == ""):
                return None
            value = (self.parameterAsInt if kind == "int" else self.parameterAsDouble)(parameters, name, context)
            if option.needs and not self._needed_on(parameters, option, context):
                return self._not_used(option, value)
            return None if option.nullable and value == option.automatic else value
        if kind == "bool":
            return self.parameterAsBoolean(parameters, name, context)
        if kind == "choice":
            index = self.parameterAsEnum(parameters, name, context)
            return None if option.none_choice and index == 0 else option.qgis_choices[index]
        if kind == "choices":
            if option.nullable and parameters.get(name) in (None, ""):  # QGIS 3.22 reads an unset multiple enum as [0]
                return None
            picked = tuple(option.qgis_choices[i] for i in self.parameterAsEnums(parameters, name, context))
            if picked or option.nullable:
                return picked or None
            raise QgsProcessingException(f"{name}: choose at least one of {', '.join(option.choices)}")
        if kind == "ints":
            return _whole_numbers(option, self.parameterAsString(parameters, name, context))
        if kind == "str":
            return self.parameterAsString(parameters, name, context) or option.default
        if kind == "crs":
            crs = self.parameterAsCrs(parameters, name, context)
            return crs_spec(crs) if crs.isValid() else option.default
        if kind in ("file", "folder", "path"):
            return self.parameterAsFile(parameters, name, context) or None
        if kind == "raster_out":
            return self.parameterAsOutputLayer(parameters, name, context) or None if parameters.get(name) else None
        return self.raster_path(parameters, name, context) if parameters.get(name) else None  # raster

    def _not_used(self, option: Option, value) -> None:
        """None for ``option``'s value while the switch it needs is off. The dialog always holds a value — the
        default, or the last one used, which QGIS keeps for every parameter, the advanced ones the user does not
        see included — so a value there is not a choice made for this run as a command-line flag is: it is not
        refused (``check_needs``) but left unused, with a warning in the log naming both labels and the fix
        (:meth:`run_tool` writes it)."""
        needed = self._needed(option)
        if value != option.default and needed is not None:
            shown = f"{value:g}" if isinstance(value, (int, float)) else str(value)
            self.__dict__.setdefault("_unused_notes", []).append(
                f"“{option.label}” {shown} is not used: it acts only with “{needed.label}”, which is off; tick "
                f"“{needed.label}” to use it (left as it is, the last value used stays in the dialog)")
        return None

    def _needed(self, option: Option) -> Option | None:
        """The option ``option`` needs (:attr:`Option.needs`) among this algorithm's :attr:`OPTIONS`, or None."""
        return next((t[option.needs] for t in self.OPTIONS if option.needs in t), None)

    def _needed_on(self, parameters, option: Option, context) -> bool:
        """Whether the (bool) option ``option`` needs (:attr:`Option.needs`) is on in ``parameters``."""
        needed = self._needed(option)
        return needed is not None and self.parameterAsBoolean(parameters, needed.qgis_name, context)

    def option_arguments(self, parameters, context, *tables: Table) -> dict:
        """The tool's keyword arguments from the parameters of ``tables`` [:attr:`OPTIONS`]."""
        out = {}
        for table in tables or self.OPTIONS:
            out.update(table.arguments({o.name: self.option_value(parameters, o, context) for o in table.values()}))
        return out
