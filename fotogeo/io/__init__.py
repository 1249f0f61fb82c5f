"""Every file format fotogeo reads or writes, one module per format: rasters (atomic outputs, DEMs, COG,
warping), vectors (GeoPackage layers, error vectors), GCP tables and QGIS ``.points``, camera and orientation
files, RPCs, EXIF/XMP, SfM projects (OpenSfM/ODM, COLMAP, orthority), JSON reports. The array layers never read a
file; the tools read and write through here."""
