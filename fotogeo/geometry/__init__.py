"""Geometry on arrays: frame cameras and exterior orientation, DEMs and height sources, the georeference
(image ↔ map through any model and the terrain), attitude of drone frames, local SfM frames, vertical references,
occlusion. Arrays in, arrays out; no file I/O."""
