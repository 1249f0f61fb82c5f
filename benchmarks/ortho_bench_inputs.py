"""``benchmarks/ortho_bench.py``'s frame inputs: the NGI frames as they are, the eBee strips' camera, orientation and
surface made once (``fotogeo triangulate`` and ``gdal_grid``), the eBee frames at half size and the NGI frames changed
one way at a time (module docstring of ``ortho_bench.py``)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("FOTOGEO_DATA", ROOT.parent / "shared" / "data"))
DRONE_STRIPS = ["IMG_2186", "IMG_2188", "IMG_2189", "IMG_2280", "IMG_2281", "IMG_2282"]
DRONE_FRAMES = ["IMG_2188", "IMG_2281"]
#: the drone_other case: the strips' other four frames, never run through ortho by the code's tuning
DRONE_OTHER = ["IMG_2186", "IMG_2189", "IMG_2280", "IMG_2282"]


def drone_inputs(folder: Path, frames=DRONE_FRAMES) -> dict:
    """The drone case's camera, orientation and surface in ``folder``, made once (module docstring), for the
    strip frames ``frames``."""
    folder.mkdir(parents=True, exist_ok=True)
    tri, dem = folder / "triangulate", folder / "dem.tif"
    img = DATA / "drone_snowpeak" / "img"
    if not (tri / "camera.yaml").exists():
        cmd = [sys.executable, "-m", "fotogeo", "triangulate", *(str(img / f"{n}.JPG") for n in DRONE_STRIPS),
               "-o", str(tri), "--self-calibration", "k1,k2,p1,p2", "-q", "--overwrite"]
        subprocess.run(cmd, check=True, env={**os.environ, "PYTHONPATH": str(ROOT), "GDAL_PAM_ENABLED": "NO"})
    if not dem.exists():
        subprocess.run(["gdal_grid", "-q", "-a", "invdist:power=2.0:smoothing=20:max_points=24", "-txe", "326900",
                        "327560", "-tye", "4157320", "4156740", "-outsize", "330", "290", "-ot", "Float32",
                        "-a_srs", "EPSG:32654", "-l", "tie_points", str(tri / "block.gpkg"), str(dem)], check=True)
    lines = [ln.split() for ln in (tri / "exterior_orientation.txt").read_text().splitlines()
             if ln.strip() and not ln.startswith("#")]
    ext = folder / "ext.csv"  # orthority's CSV: the same fields, comma-separated
    ext.write_text("".join(",".join(f) + "\n" for f in lines))
    return {"frames": [str(img / f"{n}.JPG") for n in frames], "dem": str(dem),
            "camera": str(tri / "camera.yaml"), "eo": str(tri / "exterior_orientation.txt"), "ext": str(ext),
            "crs": ["-c", "EPSG:32654"]}


def half_inputs(inp: dict, folder: Path) -> dict:
    """The drone case's frames at half size and its camera scaled to them (module docstring), made in ``folder``."""
    import yaml
    folder.mkdir(parents=True, exist_ok=True)
    frames = []
    for f in inp["frames"]:
        half = folder / (Path(f).stem + ".tif")
        if not half.exists():
            subprocess.run(["gdal_translate", "-q", "-outsize", "50%", "50%", "-r", "average", f, str(half)],
                           check=True, env={**os.environ, "GDAL_PAM_ENABLED": "NO"})
        frames.append(str(half))
    cams = yaml.safe_load(Path(inp["camera"]).read_text())
    for cam in cams.values():
        cam["im_size"] = [v // 2 for v in cam["im_size"]]
        cam["focal_len"] = cam["focal_len"] / 2
        cam["sensor_size"] = [v / 2 for v in cam["sensor_size"]]
    camera = folder / "camera.yaml"
    camera.write_text(yaml.safe_dump(cams, sort_keys=False))
    return {**inp, "frames": frames, "camera": str(camera)}


def ngi_inputs(work: Path) -> dict:
    ngi = DATA / "ngi"
    ext = work / "ext.csv"  # orthority reads the same lines as CSV
    shutil.copy(ngi / "exterior_orientation.txt", ext)
    return {"frames": sorted(str(p) for p in (ngi / "frames").glob("*.tif")), "dem": str(ngi / "dem.tif"),
            "camera": str(ngi / "interior_orientation.yaml"), "eo": str(ngi / "exterior_orientation.txt"),
            "ext": str(ext), "crs": []}


#: the NGI frames' horizontal CRS (the DEM's, Lo25 on WGS 84), given to both tools when the DEM is in another one
NGI_LO25 = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs +type=crs"


def ngi_variant(work: Path, kind: str) -> dict:
    """The NGI case with one thing changed (module docstring of ``ortho_bench.py``), made in ``work``: ``u16`` the
    frames as 3-band UInt16 (values x 257, tiled DEFLATE), ``half`` the frames at half size and the camera scaled
    (twice the ground sample distance), ``dem_utm`` the DEM warped to UTM 35S + EGM2008 heights (EPSG:32735+3855,
    bilinear, 24 m) and the map CRS given to both tools as the frames' Lo25 (:data:`NGI_LO25`)."""
    inp = ngi_inputs(work)
    env = {**os.environ, "GDAL_PAM_ENABLED": "NO"}
    if kind == "half":
        return half_inputs(inp, work / "half")
    if kind == "dem_utm":
        dem = work / "dem_utm.tif"
        subprocess.run(["gdalwarp", "-q", "-t_srs", "EPSG:32735+3855", "-r", "bilinear", "-tr", "24", "24",
                        inp["dem"], str(dem)], check=True, env=env)
        return {**inp, "dem": str(dem), "crs": ["-c", NGI_LO25], "fotogeo_args": ["--crs", NGI_LO25]}
    frames = []
    for f in inp["frames"]:
        out = work / Path(f).name
        subprocess.run(["gdal_translate", "-q", "-ot", "UInt16", "-scale", "0", "255", "0", "65535", "-co",
                        "TILED=YES", "-co", "COMPRESS=DEFLATE", f, str(out)], check=True, env=env)
        frames.append(str(out))
    return {**inp, "frames": frames}
