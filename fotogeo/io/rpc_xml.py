"""RPC XML files: Airbus DIMAP (Pleiades, SPOT 6/7, Pleiades Neo) and DigitalGlobe/Maxar (``<isd>``, WorldView,
QuickBird, GeoEye).

Both are read into an :class:`~fotogeo.orientation.rpc.Rpc` in the RPC00B pixel convention (the *centre* of the
first pixel is (0, 0)), the convention of GDAL's RPC metadata:

* DIMAP v2 (``METADATA_PROFILE`` ``PHR_SENSOR``, ``S6_SENSOR``, ``S7_SENSOR``): ground -> image coefficients in
  ``Global_RFM/Inverse_Model``, offsets and scales in ``RFM_Validity``. DIMAP numbers pixels from 1 (the centre of
  the first pixel is (1, 1), the product's ``GridEnvelope`` "low" corner), so ``LINE_OFF`` and ``SAMP_OFF`` are
  read minus 1, as GDAL's Pleiades metadata reader and rpcm do. Checked on the Pleiades rigorous-model location
  grids of ``rpc/ventoux`` (the DIMAP RPC minus 1, in fotogeo's corner convention minus 0.5, lands on the grid
  nodes) and against ``gdaltransform -rpc`` on an ``IMG_*`` file beside its ``RPC_*.XML``.
* DIMAP v3 (``PNEO_SENSOR``): coefficients in ``GroundtoImage_Values``; the first pixel's centre is the
  ``FIRST_COL`` of ``ImagetoGround_Validity_Domain`` (1 when absent), which is subtracted from both offsets
  (GDAL's rule).
* DigitalGlobe ``<isd>`` (or a bare ``<RPB>``): ``RPB/IMAGE`` with ``LINEOFFSET`` …, each coefficient list one
  space-separated element; the offsets are RPC00B's already (centre of the first pixel (0, 0)).

Only RPC00B term order is read (DigitalGlobe ``SPECID`` RPC00A is refused). Image tiles of a multi-tile DIMAP
product (``R1C2`` …) are not shifted here: the RPC describes the whole product.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InputError, one_line
from ..orientation.rpc import Rpc
from .rpc import checked_rpc, read_rpc_file_text

_DIMAP_V2 = ("PHR_SENSOR", "S6_SENSOR", "S7_SENSOR")
_DG_SCALARS = {"LINE_OFF": "LINEOFFSET", "SAMP_OFF": "SAMPOFFSET", "LAT_OFF": "LATOFFSET",
               "LONG_OFF": "LONGOFFSET", "HEIGHT_OFF": "HEIGHTOFFSET", "LINE_SCALE": "LINESCALE",
               "SAMP_SCALE": "SAMPSCALE", "LAT_SCALE": "LATSCALE", "LONG_SCALE": "LONGSCALE",
               "HEIGHT_SCALE": "HEIGHTSCALE"}
_DG_ARRAYS = {"LINE_NUM_COEFF": "LINENUMCOEF", "LINE_DEN_COEFF": "LINEDENCOEF", "SAMP_NUM_COEFF": "SAMPNUMCOEF",
              "SAMP_DEN_COEFF": "SAMPDENCOEF"}


def parse_xml(path: Path, source: str) -> ET.Element:
    """The root element of the XML file ``path``, or a one-line :class:`InputError`."""
    read_rpc_file_text(path)  # a folder or a missing file: a clear message
    try:
        return ET.parse(path).getroot()
    except (ET.ParseError, ValueError, LookupError, UnicodeError) as exc:
        raise InputError(one_line(f"{source}: not valid XML ({exc}); give a DIMAP or DigitalGlobe RPC XML or an "
                                  f"RPC text file")) from None
    except OSError as exc:
        raise InputError(one_line(f"cannot read {source}: {exc}")) from None


def _texts(elements, source: str) -> dict:
    return {el.tag: el.text.strip() for el in elements if el is not None and el.text and el.text.strip()}


def _dimap_mapping(root: ET.Element, source: str) -> dict:
    """RPC00B mapping of a DIMAP v2/v3 RPC document (module docstring), offsets still DIMAP's."""
    profile = (root.findtext(".//Metadata_Identification/METADATA_PROFILE") or "").strip()
    valid = root.find(".//RFM_Validity")
    inv = root.find(".//Inverse_Model")
    first = 1.0
    if inv is None:  # DIMAP v3 (Pleiades Neo)
        inv = root.find(".//GroundtoImage_Values")
        domain = root.find(".//ImagetoGround_Validity_Domain")
        text = domain.findtext("FIRST_COL") if domain is not None else None
        if text:
            try:
                first = float(text)
            except ValueError:
                raise InputError(f"{source}: FIRST_COL {text!r} is not a number; the RPC file is damaged") from None
    if inv is None or valid is None:
        raise InputError(f"{source}: no DIMAP Inverse_Model / GroundtoImage_Values with RFM_Validity "
                         f"(METADATA_PROFILE {profile or 'missing'}); unsupported RPC file")
    d = _texts(list(inv) + list(valid), source)
    for key in ("LINE_OFF", "SAMP_OFF"):
        if key in d:
            try:
                d[key] = float(d[key]) - first
            except ValueError:
                raise InputError(f"{source}: {key} {d[key]!r} is not a number; the RPC file is damaged") from None
    return d


def read_rpc_dimap(path) -> Rpc:
    """Read the ground -> image RPC of a DIMAP RPC XML (Pleiades, SPOT 6/7, Pleiades Neo); module docstring."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    return checked_rpc(Rpc.from_mapping(_dimap_mapping(parse_xml(path, source), source), source), source)


def read_rpc_digitalglobe(path) -> Rpc:
    """Read the ``RPB/IMAGE`` RPC00B of a DigitalGlobe/Maxar XML (``<isd>``: WorldView, QuickBird, GeoEye)."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    root = parse_xml(path, source)
    rpb = root if root.tag == "RPB" else root.find(".//RPB")
    image = rpb.find("IMAGE") if rpb is not None else None
    if image is None:
        raise InputError(f"{source}: no RPB/IMAGE element; unsupported DigitalGlobe XML (give the image's .XML "
                         f"with an <RPB> block, its .RPB or _RPC.TXT)")
    spec = (rpb.findtext("SPECID") or "RPC00B").strip().upper()
    if spec != "RPC00B":
        raise InputError(f"{source}: SPECID {spec} is not supported (only RPC00B term order); give the RPC00B file")
    d = {}
    for key, tag in _DG_SCALARS.items():
        if image.findtext(tag) is not None:
            d[key] = image.findtext(tag).strip()
    for key, tag in _DG_ARRAYS.items():
        text = image.findtext(f"{tag}List/{tag}")
        if text is not None:
            try:
                d[key] = np.array(text.split(), dtype=np.float64)
            except ValueError:
                raise InputError(f"{source}: {tag} holds a non-numeric value; the RPC file is damaged") from None
    return checked_rpc(Rpc.from_mapping(d, source), source)


def read_rpc_xml(path) -> Rpc:
    """Read an RPC XML file by its content: DIMAP (``Dimap_Document``) or DigitalGlobe (``isd`` / ``RPB``)."""
    path = Path(path)
    source = f"RPC file {str(path)!r}"
    root = parse_xml(path, source)
    if root.tag in ("isd", "RPB"):
        return read_rpc_digitalglobe(path)
    if root.tag == "Dimap_Document" or root.find(".//Inverse_Model") is not None:
        return checked_rpc(Rpc.from_mapping(_dimap_mapping(root, source), source), source)
    hint = " (a GDAL VRT: give the raster it describes)" if root.tag == "VRTDataset" else ""
    raise InputError(f"{source}: unsupported RPC XML <{root.tag}>{hint}; expected a DIMAP RPC (Pleiades, SPOT, "
                     f"Pleiades Neo) or a DigitalGlobe <isd>/<RPB> file")
