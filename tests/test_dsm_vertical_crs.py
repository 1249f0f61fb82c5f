"""The DSM's compound CRS (:func:`fotogeo.tools.dsm.outputs.with_dem_vertical`) and the lon/lat height source's
``z_range`` (:class:`fotogeo.geometry.lonlat_model._LonLatHeights`), as a reviewer found them."""
from __future__ import annotations

import pytest


@pytest.mark.parametrize("crs", ["EPSG:32735", "EPSG:32735+3855", "EPSG:32735+5773"])
def test_a_map_crs_with_a_vertical_part_joins_the_dems_vertical_crs_once(data_dir, crs):
    """A map CRS that already states heights made a compound of a compound (pyproj's CRSError): its horizontal
    part is joined to the NGI DEM's EGM2008 height, the reference the DSM's heights are in."""
    from pyproj import CRS
    from fotogeo.tools.dsm.outputs import with_dem_vertical
    out = CRS.from_user_input(with_dem_vertical(crs, "geoid", data_dir / "ngi" / "dem.tif"))
    assert [c.type_name for c in out.sub_crs_list] == ["Projected CRS", "Vertical CRS"]
    assert out.sub_crs_list[0].to_epsg() == 32735 and "EGM2008" in out.sub_crs_list[1].name


def test_a_lonlat_height_source_has_a_z_range_only_when_its_source_has_one():
    """Callers test ``hasattr(source, "z_range")`` and unpack it: a source without one must not get ``None``."""
    from fotogeo.geometry.lonlat_model import _LonLatHeights

    class Plane:
        def __call__(self, xy):
            return xy[:, 0] * 0.0

    class Ranged(Plane):
        z_range = (10.0, 20.0)

    assert not hasattr(_LonLatHeights(Plane(), lambda ll: ll), "z_range")
    assert _LonLatHeights(Ranged(), lambda ll: ll).z_range == (10.0, 20.0)
