"""``fotogeo dsm`` on an ODM reconstruction that nothing places (no ``exif/`` beside it, images without GPS): refused
naming ``--sfm-frame``, an option of dsm's own (it named triangulate's and ortho's flag, which dsm refused as unknown),
and with ``--sfm-frame grid`` the DSM lies on the ground the frames were rendered from.

The block is rendered at 69.6° N, 2.9° east of UTM 33N's central meridian, where ODM's grid offsets and OpenSfM's
topocentric frame place the cameras metres and degrees apart (tests/test_sfm_frame_evidence.py).
"""
from __future__ import annotations

import re

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from pyproj import CRS, Transformer

import rendered_oblique as ro
from fotogeo.geometry.approx_block import ApproxCamera, ApproximateBlock, ApproxShot
from fotogeo.io.opensfm import write_opensfm

LAT, LON = 69.6, 17.9
UTM33 = CRS.from_epsg(32633)
ORIGIN = tuple(Transformer.from_crs(4326, UTM33, always_xy=True).transform(LON, LAT))


@pytest.fixture(scope="module")
def odm(tmp_path_factory):
    """Two overlapping frames without GPS and their true poses as ODM writes them (grid offsets, no exif/)."""
    tmp = tmp_path_factory.mktemp("dsm_odm")
    blk = ro.oblique_block(tmp / "render", seed=5, per_strip=3, place=(UTM33.to_string(), ORIGIN))
    bare = tmp / "bare"
    bare.mkdir()
    frames = []
    for p in blk["gimbal"][:2]:
        with rasterio.open(p) as ds:
            img, tags, xmp = ds.read(1), ds.tags(), ds.tags(ns="xml:XMP")
        ro._write(bare / p.name, img, {k: v for k, v in tags.items() if not k.startswith("EXIF_GPS")},
                  next(iter(xmp.values())))
        frames.append(bare / p.name)
    shots = {n: ApproxShot(n, "cam", (e.X, e.Y, e.Z), (e.omega, e.phi, e.kappa)) for n, e in blk["truth"].items()}
    dist = dict(zip(("k1", "k2", "p1", "p2", "k3"), ro.DEWARP))
    truth = ApproximateBlock({"cam": ApproxCamera(blk["camera"], dist)}, shots, UTM33)
    (tmp / "opensfm").mkdir()
    rec = tmp / "opensfm" / "reconstruction.json"
    write_opensfm(rec, truth, (LAT, LON, 300.0), frame="grid", exif=False, extension=".tif")
    return dict(frames=frames, rec=rec, dem=blk["dem"], tmp=tmp)


def test_dsm_names_its_own_sfm_frame_and_places_the_surface_with_it(odm, tmp_path):
    from fotogeo.cli import main
    args = ["dsm", *map(str, odm["frames"]), "--eo", str(odm["rec"])]
    run = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "refused.tif"), "-q"])
    assert run.exit_code == 2, run.output
    fix = re.search(r"say which with (--[\w-]+) topocentric \(OpenSfM\) or grid \(ODM\)$", run.output.strip())
    assert fix, run.output
    assert not list(tmp_path.iterdir())
    run = CliRunner().invoke(main, [*args, fix.group(1), "grid", "-o", str(tmp_path / "dsm.tif")])
    assert run.exit_code == 0, run.output
    assert "read as grid (ODM's offsets along the UTM grid), as told" in run.output
    with rasterio.open(tmp_path / "dsm.tif") as ds:
        h = ds.read(1, masked=True)
        rows, cols = np.nonzero(~np.ma.getmaskarray(h))
        xy = np.column_stack(rasterio.transform.xy(ds.transform, rows, cols))
    truth = odm["dem"]
    tc, tr = ~truth.transform * (xy[:, 0], xy[:, 1])
    inside = (tc >= 0) & (tr >= 0) & (tc < truth.data.shape[1] - 1) & (tr < truth.data.shape[0] - 1)
    assert inside.mean() > 0.95
    err = h.compressed()[inside] - truth.data[tr[inside].astype(int), tc[inside].astype(int)]
    assert abs(np.median(err)) < 0.5, np.median(err)
