"""The option table (the fotogeo.options package): pure Python, the one source of the tools' options."""
from __future__ import annotations

import dataclasses
import importlib
import inspect
import subprocess
import sys

import pytest

from fotogeo import options as fo
from fotogeo.options.coreg import COREG
from fotogeo.options.products import MOSAIC, ORTHO
from fotogeo.errors import InputError

THIRD_PARTY = ("numpy", "click", "rasterio", "cv2", "pyproj", "shapely", "geopandas", "pyogrio", "qgis")


def test_imports_only_the_standard_library():
    """The QGIS plugin imports the table when it loads, before it knows whether numpy is installed."""
    code = ("import importlib.abc, sys\n"
            "class Block(importlib.abc.MetaPathFinder):\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            f"        if name.split('.')[0] in {THIRD_PARTY!r}: raise ImportError('blocked: ' + name)\n"
            "sys.meta_path.insert(0, Block())\n"
            "import fotogeo.options as o\n"
            "print(len(o.REGISTER), o.RegisterOptions().ratio)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == [str(len(fo.REGISTER)), "0.8"]


def test_register_options_are_the_table():
    from fotogeo.tools.register.tool import RegisterOptions
    assert RegisterOptions is fo.RegisterOptions
    f = dataclasses.fields(RegisterOptions)
    assert [x.name for x in f] == list(fo.REGISTER)
    assert {x.name: x.default for x in f} == {o.name: o.default for o in fo.REGISTER.values()}
    # the values users and the report rely on
    d = RegisterOptions()
    assert (d.detector, d.max_keypoints, d.hessian_threshold, d.ratio, d.mutual, d.model, d.ransac_threshold,
            d.check_fraction, d.seed, d.resampling, d.resolution, d.dst_crs, d.max_match_pixels, d.exaggeration,
            d.contrast, d.refine, d.reference_nodata, d.target_nodata) == \
        ("surf", 8000, None, 0.8, True, None, 3.0, 0.3, 0, "nearest", None, "auto", 16_000_000, "auto", "adaptive",
         "auto", None, None)
    d.validate()
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.ratio = 0.5


@pytest.mark.parametrize("changes, message", [
    ({"detector": "orb"}, "detector 'orb' unknown; choose one of surf, sift"),
    ({"model": "poly2"}, "model 'poly2' unknown"),
    ({"resampling": "lanczos"}, "resampling 'lanczos' unknown"),
    ({"contrast": "gamma"}, "contrast 'gamma' unknown"),
    ({"refine": "ncc"}, "refine 'ncc' unknown"),
    ({"ratio": 0.04}, "ratio must be >= 0.05 and <= 1.0"),
    ({"ratio": 1.01}, "ratio must be >= 0.05 and <= 1.0"),
    ({"check_fraction": 0.9}, "check_fraction must be >= 0.0 and <= 0.89"),
    ({"resolution": 0.0}, "resolution must be > 0.0"),
    ({"ransac_threshold": float("nan")}, "ransac_threshold must be >= 0.01"),
    ({"max_keypoints": 100.5}, "max_keypoints must be a whole number"),
    ({"seed": True}, "seed must be a whole number"),
    ({"mutual": "yes"}, "mutual must be True or False"),
    ({"detector": None}, "detector needs a value"),
])
def test_validate_checks_kind_range_and_choices(changes, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(".", r"\.")):
        fo.RegisterOptions(**changes).validate()


def test_validate_accepts_the_edges_and_numpy_numbers():
    np = pytest.importorskip("numpy")
    fo.RegisterOptions(ratio=0.05, check_fraction=0.89, ransac_threshold=0.01, resolution=1e-6, seed=np.int64(3),
                       max_keypoints=np.int32(10), target_nodata=np.float32(0), model="collinearity").validate()


def test_choice_lists_are_defined_once():
    """The array and tool modules use the table's lists (the same objects, not copies)."""
    from fotogeo.features import detect
    from fotogeo.image import contrast
    from fotogeo.io import warp
    from fotogeo.orientation import terrain
    from fotogeo.tools.register import tool as register
    assert detect.DETECTORS is fo.DETECTORS and contrast.CONTRASTS is fo.CONTRASTS
    assert terrain.TERRAIN_MODELS is fo.TERRAIN_MODELS and register.PLANAR_MODELS is fo.PLANAR_MODELS
    assert tuple(warp.RESAMPLING) == fo.RESAMPLINGS
    assert fo.REGISTER["model"].choices == fo.PLANAR_MODELS + fo.TERRAIN_MODELS
    assert fo.MATCH["ratio"] == fo.REGISTER["ratio"]  # one declaration: the same minimum in both tools


def test_models_refuse_to_import_when_the_list_differs():
    from fotogeo.models import MODELS
    assert tuple(sorted(MODELS)) == fo.ORIENTATION_MODELS
    code = ("import fotogeo.options as o\n"
            "o.ORIENTATION_MODELS = o.ORIENTATION_MODELS[:-1]\n"
            "import fotogeo.models\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "ImportError" in r.stderr and "update the list in fotogeo/options/shared.py" in r.stderr


def test_groups_gather_field_options():
    values = {o.name: o.default for o in fo.TRANSFER.values()}
    assert fo.TRANSFER.arguments(values) == {"search_radius": 32, "half_window": 10, "id_field": "id",
                                             "ref_fields": ("ref_col", "ref_row"), "approx_fields": ("col", "row")}
    values = {o.name: o.default for o in fo.GCP.values()}
    args = fo.GCP.arguments({**values, "z_field": "h"})
    assert args["fields"] == {"col": "col", "row": "row", "z": "h", "role": "role", "id": "id"}
    assert not any(k.endswith("_field") for k in args)


def test_declaration_errors():
    with pytest.raises(ValueError, match="kind"):
        fo.Option("x", "complex")
    with pytest.raises(ValueError, match="twice"):
        fo.Table(fo.SEED, fo.SEED)


#: tool -> (option tables, keyword-only arguments knowingly not options: outputs, internals)
TOOLS = {
    "tools.register.tool.register": ((fo.REGISTER_TERRAIN,), {"vectors", "field", "report", "options", "tie_points"}),
    "tools.orient.tool.orient": ((fo.ORIENT, fo.GCP), {"report", "vectors", "plot", "points", "rpc", "gcp_tiff",
                                                  "rectify"}),
    "tools.orient.compare.compare_models": ((fo.COMPARE, fo.GCP), {"table", "markdown", "html", "plots"}),
    "tools.register.fuse.fuse_raster": ((fo.FUSE,), {"sample_pixels", "block_rows"}),
    "tools.points.transfer.transfer_gcps": ((fo.TRANSFER,), set()),
    "tools.points.targets.measure_targets": ((fo.TARGETS,), set()),
    "tools.points.layers.points_to_layer": ((fo.POINTS_TO_LAYER,), {"layer"}),
    "tools.points.layers.layer_to_points": ((fo.LAYER_TO_POINTS,), {"layer"}),
    "tools.demo.tool.run_demo": ((fo.DEMO,), set()),
    "tools.orient.rpc_bias.rpc_bias": ((fo.RPC_BIAS,), {"report"}),
    "tools.triangulate.triangulate": ((fo.TRIANGULATE,), {"gcps", "reference"}),
    "tools.coreg.tool.coregister": ((COREG,), {"shifts", "field", "report"}),
    "tools.ortho.tool.ortho": ((ORTHO,), set()),
    "tools.ortho.mosaic.mosaic": ((MOSAIC,), {"seamlines"}),
}


@pytest.mark.parametrize("tool", sorted(TOOLS))
def test_every_tool_keyword_is_in_its_table(tool):
    """A new keyword of a tool must be declared in its table (or knowingly left out): then the command
    line and QGIS get it too. Table options must be keywords of the tool (``**options`` takes any)."""
    module, func = tool.rsplit(".", 1)
    sig = inspect.signature(getattr(importlib.import_module(f"fotogeo.{module}"), func))
    tables, skip = TOOLS[tool]
    table_args = {}
    for t in tables:
        table_args.update(t.arguments({o.name: o.default for o in t.values()}))
    keywords = {k for k, p in sig.parameters.items() if p.kind == p.KEYWORD_ONLY} - {"overwrite", "progress"}
    assert not keywords - skip - set(table_args), f"{tool}: keywords without an option"
    takes_any = any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())
    assert takes_any or set(table_args) <= keywords, f"{tool}: options the tool does not take"
    needs = {o.name for t in tables for o in t.values() if o.needs}  # not given: None, the default with the other
    for name, value in table_args.items():  # the table's defaults are the tool's (fields=None: the same names)
        default = sig.parameters[name].default if name in sig.parameters else inspect.Parameter.empty
        if name in needs:
            assert default is None, (tool, name)
            continue
        if default is not inspect.Parameter.empty and not (default is None and isinstance(value, dict)):
            assert value == (tuple(default) if isinstance(default, (list, tuple)) else default), (tool, name)
