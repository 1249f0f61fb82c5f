"""What every fotogeo Processing algorithm shares.

- fotogeo is imported lazily, inside ``processAlgorithm`` (:meth:`FotogeoAlgorithm.tool`),
  after checking the third-party packages the algorithm needs, so the plugin loads even
  when a dependency is missing and the algorithm then says exactly which one and how to
  install it;
- the tools' progress protocol ``progress(fraction, message) -> bool`` is bridged to the
  Processing feedback (:func:`progress_callback`): progress bar, progress text, cancel;
- every :class:`fotogeo.errors.FotogeoError` — a cancel included — becomes a
  :class:`QgsProcessingException` carrying the same message (:meth:`FotogeoAlgorithm.run_tool`);
- the tool options are parameters generated from the algorithm's option tables
  (:attr:`FotogeoAlgorithm.OPTIONS`, from :mod:`fotogeo.options`, see :func:`parameter`) and
  read back into the tool's keyword arguments (:meth:`FotogeoAlgorithm.option_arguments`).
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
import threading

from qgis.core import (
    QgsApplication,
    QgsCoordinateReferenceSystem,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProviderRegistry,
    QgsRasterLayer,
)
from qgis.PyQt.QtCore import QCoreApplication

from fotogeo.options import Option, Table  # standard library only: loads without fotogeo's dependencies

#: import name -> pip distribution name of the third-party packages fotogeo uses.
DEPENDENCIES = {"numpy": "numpy<2", "rasterio": "rasterio", "pyproj": "pyproj", "shapely": "shapely",
                "geopandas": "geopandas", "pyogrio": "pyogrio", "cv2": "opencv-python-headless"}

REFERENCES = {
    "dihkan": "Dihkan (2019): automatic registration of multi-epoch, multi-sensor aerial images to an "
              "orthophoto with PCA band fusion, SURF, RANSAC and a homography.",
    "surf": "Bay, H., Ess, A., Tuytelaars, T., Van Gool, L. (2008): Speeded-Up Robust Features (SURF). "
            "Computer Vision and Image Understanding 110(3), 346-359.",
    "sift": "Lowe, D. G. (2004): Distinctive image features from scale-invariant keypoints. IJCV 60(2), 91-110.",
    "ransac": "Fischler, M. A., Bolles, R. C. (1981): Random sample consensus. Comm. ACM 24(6), 381-395.",
}


def tr(text: str) -> str:
    return QCoreApplication.translate("fotogeo", text)


def missing_dependencies(names=tuple(DEPENDENCIES), import_them: bool = True) -> list[tuple[str, str]]:
    """``[(import name, reason)]`` of the packages in ``names`` that cannot be imported.

    With ``import_them`` False only their presence is checked (cheap; used at load time).
    """
    missing = []
    for name in names:
        try:
            if import_them:
                importlib.import_module(name)
            elif name not in sys.modules and importlib.util.find_spec(name) is None:
                missing.append((name, "not installed"))
        except Exception as e:  # noqa: BLE001 - ImportError, or a broken binary wheel (e.g. numpy ABI)
            missing.append((name, f"{type(e).__name__}: {e}"))
    return missing


def dependency_message(missing) -> str:
    """One clear message naming what is missing and the pip command that installs it."""
    names = ", ".join(f"{n} ({why})" for n, why in missing)
    pip = " ".join(f'"{DEPENDENCIES.get(n, n)}"' for n, _ in missing)
    return (f"fotogeo cannot run: the Python package(s) {names} cannot be imported by QGIS's Python "
            f"({sys.executable}). Install them into that Python, e.g. `python3 -m pip install {pip}` "
            f"(on Debian/Ubuntu also: apt install python3-rasterio python3-geopandas python3-opencv), "
            f"then restart QGIS.")


_PINNED_PROJ_CONTEXTS: dict = {}


def pin_pyproj_context() -> None:
    """Keep this OS thread's PROJ context of pyproj alive for the life of the process.

    QGIS runs algorithms on its task manager's worker threads, which are not Python threads:
    every call into Python gets a fresh Python thread state. pyproj (3.7) keeps the thread's
    PROJ context pointer in thread-specific storage but the object that destroys it in a
    ``threading.local``, which dies with the thread state at the end of the call: the next
    algorithm run on the same worker thread then uses a destroyed context ("no database
    context specified", or a crash). Holding that object here keeps the context valid: one per
    OS thread id, replaced when a new thread reuses the id of a finished one (pyproj issue 1509,
    fixed upstream by pyproj pull request 1541, not released as of pyproj 3.7.2).
    """
    try:
        from pyproj import _context
        _context._set_context_data_dir()  # creates this thread's context, or finds the existing one
        manager = _context.get_context_manager()
    except Exception:  # noqa: BLE001 - pyproj missing, or without these internals: run as is
        return
    if manager is not None:  # None: the context was made by an earlier call on this thread, and pinned then
        _PINNED_PROJ_CONTEXTS[threading.get_ident()] = manager


def progress_callback(feedback):
    """A fotogeo progress callback driving a :class:`QgsProcessingFeedback`.

    ``fraction`` (0..1) → ``setProgress(100 * fraction)``, a new message → ``setProgressText``;
    returns ``not feedback.isCanceled()`` (False asks the tool to stop and clean up).
    """
    last = [None]

    def progress(fraction: float, message: str = "") -> bool:
        if feedback is None:
            return True
        feedback.setProgress(100.0 * min(max(float(fraction), 0.0), 1.0))
        if message and message != last[0]:
            last[0] = message
            feedback.setProgressText(message)
        return not feedback.isCanceled()

    return progress


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
    elif kind == "file":
        p = QgsProcessingParameterFile(name, label, optional=True, fileFilter=option.file_filter)
    else:  # raster
        p = QgsProcessingParameterRasterLayer(name, label, optional=True)
    if option.advanced:
        p.setFlags(p.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
    return p


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

    #: stable lowercase algorithm id; display name; group (id, name)
    ALG_ID = ""
    DISPLAY = ""
    GROUP = ("", "")
    #: import names of the third-party packages this algorithm needs
    REQUIRES: tuple = tuple(DEPENDENCIES)
    HELP = ""
    #: the option tables (:mod:`fotogeo.options`) whose options are parameters of this algorithm
    OPTIONS: tuple[Table, ...] = ()

    def name(self):
        return self.ALG_ID

    def displayName(self):
        return tr(self.DISPLAY)

    def group(self):
        return tr(self.GROUP[1])

    def groupId(self):
        return self.GROUP[0]

    def shortHelpString(self):
        text = tr(self.HELP)
        missing = missing_dependencies(self.REQUIRES, import_them=False)
        if missing:
            text += "\n\n<b>" + tr("Not runnable yet") + ":</b> " + dependency_message(missing)
        return text

    def icon(self):
        return QgsApplication.getThemeIcon("/processingAlgorithm.svg")

    def createInstance(self):
        return type(self)()

    # -- running a tool ------------------------------------------------------------------
    def tool(self, module: str, attr: str):
        """Import ``fotogeo.<module>.<attr>`` now; missing dependencies → one clear exception."""
        missing = missing_dependencies(self.REQUIRES)
        if missing:
            raise QgsProcessingException(dependency_message(missing))
        try:
            mod = importlib.import_module(f"fotogeo.{module}")
        except ImportError as e:
            missing = missing_dependencies(tuple(DEPENDENCIES))
            if missing:
                raise QgsProcessingException(dependency_message(missing)) from None
            raise QgsProcessingException(f"fotogeo could not be imported ({e}); reinstall the fotogeo plugin") from None
        return getattr(mod, attr)

    def run_tool(self, func, *args, feedback=None, **kwargs):
        """Call a fotogeo tool with a progress callback; FotogeoError → QgsProcessingException."""
        from fotogeo.errors import Cancelled, FotogeoError
        pin_pyproj_context()
        try:
            return func(*args, progress=progress_callback(feedback), **kwargs)
        except Cancelled as e:
            raise QgsProcessingException(str(e)) from None
        except FotogeoError as e:
            raise QgsProcessingException(str(e)) from None

    # -- parameters ----------------------------------------------------------------------
    def raster_path(self, parameters, name: str, context) -> str:
        """Local file path of a raster-layer parameter (a GDAL file), or a clear exception."""
        layer = self.parameterAsRasterLayer(parameters, name, context)
        if layer is None or not isinstance(layer, QgsRasterLayer):
            raise QgsProcessingException(self.invalidRasterError(parameters, name))
        if layer.providerType() != "gdal":
            raise QgsProcessingException(
                f"{name}: layer {layer.name()!r} comes from the {layer.providerType()!r} provider, not from a "
                f"raster file; save it as a GeoTIFF (Export > Save As) and use that file")
        parts = QgsProviderRegistry.instance().decodeUri("gdal", layer.source())
        return parts.get("path") or layer.source()

    def raster_output(self, parameters, name: str, context) -> str:
        """Path of a raster destination parameter; fotogeo writes GeoTIFF, so it must end in .tif/.tiff."""
        path = self.parameterAsOutputLayer(parameters, name, context)
        if not path.lower().endswith((".tif", ".tiff")):
            raise QgsProcessingException(f"{name}: fotogeo writes GeoTIFF; give a file name ending in .tif "
                                         f"(got {path!r})")
        return path

    def add_options(self, table: Table):
        """Add the parameters of the options of ``table``, in table order."""
        for option in table.values():
            self.addParameter(parameter(option))

    def option_value(self, parameters, option: Option, context):
        """The value of ``option``'s parameter as the tool takes it (None for empty / automatic)."""
        name, kind = option.qgis_name, option.kind
        if kind in ("int", "float"):
            given = parameters.get(name)
            if option.nullable and option.automatic is None and (given is None or str(given).strip() == ""):
                return None
            value = (self.parameterAsInt if kind == "int" else self.parameterAsDouble)(parameters, name, context)
            return None if option.nullable and value == option.automatic else value
        if kind == "bool":
            return self.parameterAsBoolean(parameters, name, context)
        if kind == "choice":
            index = self.parameterAsEnum(parameters, name, context)
            return None if option.none_choice and index == 0 else option.qgis_choices[index]
        if kind == "choices":
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
        if kind == "file":
            return self.parameterAsFile(parameters, name, context) or None
        return self.raster_path(parameters, name, context) if parameters.get(name) else None  # raster

    def option_arguments(self, parameters, context, *tables: Table) -> dict:
        """The tool's keyword arguments from the parameters of ``tables`` [:attr:`OPTIONS`]."""
        out = {}
        for table in tables or self.OPTIONS:
            out.update(table.arguments({o.name: self.option_value(parameters, o, context) for o in table.values()}))
        return out
