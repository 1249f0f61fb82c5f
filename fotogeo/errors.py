"""The one error hierarchy of fotogeo.

Every error fotogeo raises on purpose derives from :class:`FotogeoError`, and from the
built-in exception a Python user would expect (``ValueError`` for bad values, ``OSError``
for files). Messages name the offending input and say how to fix it; the CLI and the QGIS
provider show them as they are, without a traceback.
"""
from __future__ import annotations


class FotogeoError(Exception):
    """Base class of every error fotogeo raises deliberately.

    ``option``: the name of the tool option the message is about (e.g. ``"half_window"``), when it is
    one; the command line then names it by its flag and QGIS by its parameter's label
    (:func:`in_callers_words`), the Python API keeps the keyword.

    ``also``: further options the message names (e.g. the one ``option`` needs), named alike by each caller.

    ``frames``: the names of the images (frames) the message refuses, when it is about some of a block's: a caller
    that adds context (e.g. the pairs tried by a refused triangulation) puts theirs first without reading the text.
    """

    def __init__(self, *args, option: str | None = None, frames=(), also=()):
        super().__init__(*args)
        self.option = option
        self.also = tuple(also)
        self.frames = tuple(map(str, frames))


class InputError(FotogeoError, ValueError):
    """An input value, array or parameter is invalid (names it and says what would be valid)."""


class RasterError(FotogeoError, OSError):
    """A raster cannot be read or lacks what the operation needs (e.g. a georeference)."""


class VectorError(FotogeoError, OSError):
    """A vector layer or points file cannot be read or lacks what the operation needs."""


class OutputError(FotogeoError, OSError):
    """An output cannot be written (exists without overwrite, equals an input, folder missing)."""


class MatchingError(FotogeoError, RuntimeError):
    """Images could not be matched: too few keypoints, matches or inliers (says how many)."""


class ModelError(FotogeoError, ValueError):
    """A geometric model cannot be estimated: too few points, degenerate or ill-posed geometry."""


class Cancelled(FotogeoError):
    """The progress callback asked to stop; no partial output is left behind."""


class FotogeoWarning(UserWarning):
    """Base class of fotogeo's warnings: a result was produced but deserves caution."""


class InputNote(FotogeoWarning):
    """How an input was read when the file leaves a choice that changes the result (e.g. the local frame of an
    SfM reconstruction): shown among the run's first lines (the command line prints it as ``Note:``)."""


class IllPosedWarning(FotogeoWarning):
    """A model was estimated but is poorly determined (flat terrain, too few or clustered points)."""


#: WKT keywords that open a CRS definition (WKT1 and WKT2)
_WKT_KEYWORDS = ("PROJCRS", "GEOGCRS", "GEODCRS", "BOUNDCRS", "COMPOUNDCRS", "VERTCRS", "ENGCRS", "PROJCS",
                 "GEOGCS", "GEOCCS", "COMPD_CS", "VERT_CS", "LOCAL_CS")


def _shorten_wkt(text: str) -> str:
    """Replace each WKT CRS definition in ``text`` by ``KEYWORD["name"]`` (its name only)."""
    import re
    out, pos = [], 0
    for m in re.finditer(r"\b(" + "|".join(_WKT_KEYWORDS) + r")\s*\[", text):
        if m.start() < pos:
            continue  # nested inside the definition already shortened
        depth, end = 0, len(text)
        for i in range(m.end() - 1, len(text)):
            depth += {"[": 1, "]": -1}.get(text[i], 0)
            if depth == 0:
                end = i + 1
                break
        name = re.match(r'\s*"([^"]*)"', text[m.end():end])
        out.append(text[pos:m.start()] + f'{m.group(1)}["{name.group(1) if name else "…"}"]')
        pos = end
    return "".join(out) + text[pos:]


def one_line(text, limit: int | None = 800, value_limit: int = 120) -> str:
    """``text`` as one line for an error message: whitespace collapsed, WKT CRS definitions
    shortened to their names, quoted values longer than ``value_limit`` and the whole text
    longer than ``limit`` characters cut with "…" — before the last " — " (the fix), when the fix is short.
    ``limit`` None: never cut (fotogeo's own refusals, composed to be read whole, issue 32).

    >>> one_line('CRS PROJCS["WGS 84 / UTM zone 35N",GEOGCS["WGS 84",DATUM["x"]]] is\\n  projected')
    'CRS PROJCS["WGS 84 / UTM zone 35N"] is projected'
    >>> one_line("got '" + "x" * 1000 + "'").count("x"), "…" in one_line("got '" + "x" * 1000 + "'")
    (68, True)
    """
    import re
    text = " ".join(_shorten_wkt(str(text)).split())
    half = value_limit // 2
    text = re.sub(r"(?<!\w)'([^']{%d,})'(?!\w)" % (value_limit + 1), lambda m: f"'{m.group(1)[:half]}…{m.group(1)[-8:]}'", text)
    if limit is None or len(text) <= limit:
        return text
    head, sep, fix = text.rpartition(" — ")  # the fix comes last: cut the detail before it, never the fix
    if sep and len(fix) < limit // 2:
        return text[:limit - len(fix) - len(sep) - 1] + "…" + sep + fix
    return text[:limit - 1] + "…"


def in_callers_words(message: str, option: str | None, words: str | None) -> str:
    """``message`` with the option name ``option`` (its first occurrence as a whole word) replaced by
    ``words``: the caller's name for it (a command-line flag, a QGIS parameter label).

    >>> in_callers_words("half_window 5000 is too large", "half_window", "--half-window")
    '--half-window 5000 is too large'
    >>> in_callers_words("nothing to rename", None, "--x")
    'nothing to rename'

    A switch given as ``option=True`` is the flag alone:

    >>> in_callers_words("'o.tif' exists; pass overwrite=True to replace it", "overwrite", "--overwrite")
    "'o.tif' exists; pass --overwrite to replace it"

    A message that spells the flag already has it replaced (a QGIS label), and a file named after the option keeps
    its name:

    >>> in_callers_words("--model orthorectifies through its fitted model", "model", "Fitted model file")
    'Fitted model file orthorectifies through its fitted model'
    >>> in_callers_words("cannot read 'model.json': model needed", "model", "--model")
    "cannot read 'model.json': --model needed"
    >>> in_callers_words("file '/data/crs/eo.txt' is off — check the CRS it is read in (crs)", "crs", "--crs")
    "file '/data/crs/eo.txt' is off — check the CRS it is read in (--crs)"

    A switch turned off, ``option=False``, is its negative flag (which a QGIS dialog's
    :func:`fotogeo.options.table.in_labels` reads as its box unticked):

    >>> in_callers_words("or keep it with qgis_style=False", "qgis_style", "--qgis-style")
    'or keep it with --no-qgis-style'
    """
    import re
    if not option or not words:
        return message

    def said(m):
        return "--no-" + words[2:] if m.group(1) == "=False" and words.startswith("--") else words
    return re.sub(r"(?<![\w\-/\\])(?:--)?%s(=True|=False)?(?![\w\-/\\]|\.\w)" % re.escape(option), said,
                  message, count=1)


#: library warnings that tell a user nothing to act on, silenced: numpy's floating-point and empty/NaN-slice
#: notes (fotogeo checks the numbers that matter itself: non-finite results are refused or reported),
#: rasterio's note on an image without georeference (the tools that need one say so)
_SILENCED = ("All-NaN slice encountered", "All-NaN axis encountered", "Mean of empty slice",
             "Degrees of freedom <= 0", "encountered in", "invalid value encountered", "Dataset has no geotransform")
#: library warnings (by class name) that carry information, in fotogeo's words
_TRANSLATED = {
    "NodataShadowWarning": "a raster has both a nodata value and an alpha band: its empty pixels are the ones "
                           "equal to the nodata value, the alpha band is not used as a mask; remove the nodata "
                           "value (gdal_edit.py -unsetnodata) to mask by the alpha band",
    "NotGeoreferencedWarning": None,
}


#: library warnings (by a piece of their text) that carry information, in fotogeo's words
_TRANSLATED_TEXT = {
    "'crs' was not provided": "a vector output has no CRS because its input has none; assign one (QGIS: Layer "
                              "Properties > Source, or ogr2ogr -a_srs) before overlaying it on a map",
}


def warning_line(message, category) -> str | None:
    """The one line a user is shown for a warning (fotogeo's own as they are, a library's translated into
    fotogeo's words or silenced: None). The one rule of the command line and the QGIS worker.

    >>> warning_line("All-NaN slice encountered", RuntimeWarning) is None
    True
    >>> warning_line("flat terrain:\\n  use a 2-D model", IllPosedWarning)
    'flat terrain: use a 2-D model'
    """
    name = getattr(category, "__name__", "")
    if isinstance(category, type) and issubclass(category, FotogeoWarning):
        return one_line(str(message))
    if name in _TRANSLATED:
        return _TRANSLATED[name]
    text = one_line(str(message))
    if any(s in text for s in _SILENCED):
        return None
    return next((v for k, v in _TRANSLATED_TEXT.items() if k in text), text)
