"""Height sources for tests of the ray–DEM intersection (fotogeo.geometry.georeference.intersect_terrain)."""
from __future__ import annotations


class CountingDem:
    """A height source that records how many points each call samples."""

    def __init__(self, dem):
        self.dem, self.sampled = dem, []

    def heights_and_gradient(self, XY):
        self.sampled.append(len(XY))
        return self.dem.heights_and_gradient(XY)
