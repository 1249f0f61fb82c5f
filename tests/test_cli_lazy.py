"""The command line imports what the sub-command it runs uses: ``fotogeo ortho`` run in a fresh process on a
rendered scene leaves the other sub-commands' modules and their heavy dependencies out of ``sys.modules``; the
name → module table of the lazy group is what the modules define; ``--version`` still answers. Every command freezes
what is left at the process's exit (``gc.freeze`` in an ``atexit`` handler), not during the run: the interpreter's
last collections skip it (docs/benchmarks/products.md, *The process's exit*)."""
from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import rasterio
from click.testing import CliRunner

import box_scene as bs
import fotogeo
from fotogeo.cli import COMMANDS, main

ROOT = Path(__file__).resolve().parents[1]

#: run the CLI in-process, then print the modules it imported (JSON), and at the process's exit, after the handlers
#: the run registered (last in, first out), the count of frozen objects (JSON) on the last line
RUN = """
import atexit, gc, json, sys
atexit.register(lambda: print(json.dumps(gc.get_freeze_count())))
from fotogeo.cli import main
main.main(sys.argv[1:], standalone_mode=False)
print(json.dumps([sorted(sys.modules), gc.get_freeze_count()]))
"""

#: modules ``ortho`` never uses: other sub-commands, their tools and heavy libraries; pyproj too when, as here, the
#: map CRS is the DEM's and the orientation file states none (the CRSs are rasterio's, :mod:`fotogeo.crs`);
#: ctypes.util, whose ``find_library`` runs ``ldconfig -p`` in a child process (the C library is the process's own,
#: :mod:`fotogeo.io.clocale`)
NOT_ON_ORTHO = ["fotogeo.cli.triangulate", "fotogeo.cli.dsm", "fotogeo.cli.register", "fotogeo.cli.mosaic",
                "fotogeo.tools.triangulate", "fotogeo.tools.dsm", "fotogeo.tools.register", "fotogeo.matching",
                "fotogeo.features", "scipy", "sklearn", "geopandas", "shapely", "pyogrio", "fiona", "matplotlib",
                "dask", "distributed", "laspy", "pyproj", "ctypes.util"]


def test_command_table_is_what_the_modules_define():
    defined = {}
    for module in dict.fromkeys(COMMANDS.values()):
        cmd = importlib.import_module(f"fotogeo.cli.{module}").command
        defined.update({c.name: module for c in (cmd if isinstance(cmd, list) else [cmd])})
    assert defined == COMMANDS
    assert sorted(main.commands) == sorted(COMMANDS)
    assert all(any(p.name == "json_output" for p in c.params) for c in main.commands.values())


def test_version_is_read_when_asked():
    r = CliRunner().invoke(main, ["--version"])
    assert r.exit_code == 0 and r.output == f"fotogeo, version {fotogeo.__version__}\n"


def test_ortho_imports_only_what_it_uses(tmp_path):
    scene = bs.write_scene(tmp_path)
    out = tmp_path / "ortho.tif"
    args = ["ortho", str(scene["frame"]), "-o", str(out), "--dem", str(scene["dsm"]), "--camera",
            str(scene["camera"]), "--eo", str(scene["eo"]), "--resolution", "0.5", "-q"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "GDAL_PAM_ENABLED": "NO"}
    p = subprocess.run([sys.executable, "-c", RUN, *args], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    *_, run, at_exit = p.stdout.strip().splitlines()
    imported, during = json.loads(run)
    frozen = json.loads(at_exit)
    modules = set(imported)
    assert {"fotogeo.cli.ortho", "fotogeo.tools.ortho.tool", "cv2", "rasterio"} <= modules
    loaded = [m for m in NOT_ON_ORTHO if m in modules or any(n.startswith(m + ".") for n in modules)]
    assert loaded == [], f"fotogeo ortho imported {loaded}"
    assert during == 0, "fotogeo ortho froze objects during the run: a process running it again would keep them"
    assert frozen > 10000, f"fotogeo ortho froze {frozen} objects at exit: its imports' (tens of thousands) expected"
    with rasterio.open(out) as ds:  # the nadir tag, written with the file
        assert len(ds.tags()["FOTOGEO_NADIR"].split()) == 2
        assert ds.overviews(1) == [f for f in (2, 4, 8) if min(ds.shape) / f >= 256]  # built with the file
