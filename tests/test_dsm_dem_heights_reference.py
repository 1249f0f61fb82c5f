"""``fotogeo dsm`` with frames and a DEM: the DSM's heights are the orientation's (the DEM only guides the search),
so their reference is the DEM's only where the DEM's heights are measured to agree with them
(:func:`fotogeo.tools.dsm.dem_guide.heights_reference`); and a geoid DEM given with ``--geoid`` bounds the run's
heights shifted by the undulations, as it guides the pairs (:func:`fotogeo.tools.dsm.plan.dem_range`)."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio

from fotogeo.tools.dsm import frames, tool
from fotogeo.tools.dsm.inputs import SourceImage
from fotogeo.tools.ortho.inputs import image_models

from dsm_scenes import make_scene, write_dem


@pytest.fixture(scope="module")
def nadir(tmp_path_factory):
    return make_scene("nadir", tmp_path_factory.mktemp("nadir"))


def _dem(sc, path, *, shift=0.0, crs="EPSG:32635+5773", value=None):
    """The scene's true surface as a 20 m DEM, ``shift`` m higher (or every cell ``value``), in ``crs``."""
    write_dem(sc, path)
    with rasterio.open(path, "r+") as ds:
        z = ds.read(1).astype(float) + shift if value is None else np.full((ds.height, ds.width), value)
        ds.write(z.astype(np.float32), 1)
        ds.crs = rasterio.crs.CRS.from_user_input(crs)
    return str(path)


def _heights(sc, dem, **kw):
    ims = image_models(sc["images"][:2], sc["crs"], camera=sc["camera"], eo=sc["eo"])
    views = [frames.frame_view(im) for im in ims]
    return tool._heights(ims, views, [SourceImage(im.path, None) for im in ims], dem, kw.get("dem_heights", "auto"),
                         kw.get("geoid"), sc["crs"], {})


def test_a_geoid_dem_labels_the_dsm_only_where_it_fits_the_orientation(nadir, tmp_path):
    """Before: a geoid DEM 30 m from the orientation's heights (the offset warned) labelled the DSM ``geoid`` (and
    gave it the DEM's EGM96 height) although its heights are the orientation's; now not stated, with a note. A
    geoid DEM the heights agree with at the sparse matches still labels it (NGI's EGM2008)."""
    _, _, ref, notes, _ = _heights(nadir, _dem(nadir, tmp_path / "off.tif", shift=-30.0))
    assert ref is None
    assert any("reference not stated" in n and "+30" in n for n in notes), notes
    _, _, ref, _, _ = _heights(nadir, _dem(nadir, tmp_path / "dem.tif"))
    assert ref == "geoid"


def test_with_geoid_the_runs_heights_are_the_shifted_dems(nadir, tmp_path):
    """A geoid DEM 60 m under the ellipsoidal surface and undulations of 60 m: the run's range is the shifted
    DEM's, as with the ellipsoidal DEM itself (before: 60 m lower, the raw DEM's; the pair choice and the default
    cell were measured there)."""
    lo, hi, ref, _, _ = _heights(nadir, _dem(nadir, tmp_path / "dem.tif", shift=-60.0),
                                 geoid=_dem(nadir, tmp_path / "n.tif", crs="EPSG:32635", value=60.0))
    elo, ehi, _, _, _ = _heights(nadir, _dem(nadir, tmp_path / "e.tif", crs="EPSG:32635"))
    assert ref == "ellipsoid"
    # (the DEM's window under the images follows its heights: a few metres of its range differ)
    assert abs(lo - elo) < 5.0 and abs(hi - ehi) < 5.0, (lo, hi, elo, ehi)
