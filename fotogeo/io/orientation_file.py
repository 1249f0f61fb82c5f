"""One entry for every orientation file ``--eo`` accepts: the reader is picked by the file's type.

* ``*.txt`` — fotogeo's ``name X Y Z omega phi kappa`` lines (:func:`fotogeo.io.camera.read_exterior_orientation`;
  the map CRS is the block's), read by the caller: :func:`read_orientation_file` returns None;
* ``*.json`` — OpenSfM/ODM ``reconstruction.json`` (:func:`fotogeo.io.opensfm.read_opensfm`; ODM's
  ``cameras.json`` beside it is used for the cameras);
* a folder (``sparse/0/``), or its ``images.txt`` / ``cameras.txt`` / ``images.bin`` / ``cameras.bin`` — a COLMAP
  model (:func:`fotogeo.io.colmap.read_colmap`; its coordinates are in ``crs``, or ECEF, or COLMAP's own frame
  aligned to the images' GPS); a folder without a model is refused naming the models found below it;
* ``*.geojson`` / ``*.csv`` — orthority's exterior parameters (:func:`fotogeo.io.orthority.read_orthority`) with
  the interior parameters of ``camera`` (orthority's YAML).

Each returns the one :class:`~fotogeo.geometry.approx_block.ApproximateBlock`. With the ``images`` themselves,
their own EXIF GPS is evidence (:mod:`fotogeo.io.sfm_frame`): it decides the local frame of an OpenSfM/ODM
reconstruction (``sfm_frame`` ``auto``), and every file's camera centres must agree with it within 3σ
horizontally, else the file is refused by name (a COLMAP model aligned to that GPS here was tested by its
alignment: :mod:`fotogeo.io.colmap_align`). A distortion-free camera (the model of undistorted images) given with
images whose own calibration states a lens distortion is refused (:mod:`fotogeo.io.sfm_lens`; not when a ``camera``
replaces the file's cameras). An OpenSfM reading and a COLMAP alignment are shown as an
:class:`~fotogeo.errors.InputNote`.
"""
from __future__ import annotations

import warnings
from pathlib import Path

from ..errors import InputError, InputNote

_COLMAP = ("images.txt", "cameras.txt", "images.bin", "cameras.bin")


def cameras_from_camera_file(path) -> bool:
    """Whether the block of ``path`` takes its cameras from the camera file itself (orthority's exterior parameters
    with their interior YAML): then that file is not to be read again as fotogeo's own camera YAML."""
    return Path(path).suffix.lower() in (".geojson", ".csv")


def is_block_file(path) -> bool:
    """Whether ``path`` is read into a block (every type but fotogeo's ``name X Y Z omega phi kappa`` lines)."""
    p = Path(path)
    return not (p.suffix.lower() == ".txt" and not p.is_dir() and p.name.lower() not in _COLMAP)


def read_orientation_file(path, crs=None, camera=None, *, sfm_frame: str = "auto", images=()):
    """The :class:`ApproximateBlock` of ``path`` (module docstring), or None for a ``.txt`` EO file."""
    p = Path(path)
    if not is_block_file(p):
        return None  # fotogeo's lines, read by the caller: no block, so the images' GPS is not read either
    from .sfm_frame import check_gps, images_gps  # function level: EXIF and the SfM frames only for a block file
    gps = images_gps(images) if images else {}
    block = _read(p, crs, camera, sfm_frame, gps, images)
    if block is None:
        return None
    is_sfm = p.suffix.lower() == ".json" and not p.is_dir()
    from .colmap_align import aligned_to_gps
    agree = (check_gps(block, gps, f"orientation file {str(p)!r}", "sfm_frame" if is_sfm else None)
             if gps and not aligned_to_gps(block) else "")
    if agree:
        block = block.with_notes(agree)
    from .sfm_lens import check_lens
    replaced = camera is not None and not cameras_from_camera_file(p)  # the callers' --camera replaces its cameras
    lens = check_lens(block, images, p) if images and not replaced else ""
    if lens:
        warnings.warn(f"orientation file {str(p)!r}: {lens}", InputNote, stacklevel=2)
    if is_sfm or block.frame_reading:  # how an SfM frame was read or aligned: among the run's first lines
        warnings.warn(f"orientation file {str(p)!r}: {block.frame_reading}" + (f"; {agree}" if agree else ""),
                      InputNote, stacklevel=2)
    return block


def _read(p: Path, crs, camera, sfm_frame: str, gps, images=()):
    suffix = p.suffix.lower()
    if p.is_dir() or p.name.lower() in _COLMAP:
        from .colmap import read_colmap
        return read_colmap(p if p.is_dir() else p.parent, crs=crs, gps=gps)
    if suffix == ".txt":
        return None
    if suffix == ".json":
        from .opensfm import read_opensfm
        cams = p.parent / "cameras.json"
        from .block import frame_key
        return read_opensfm(p, cams if cams.exists() and cams != p else None, crs=crs, frame=sfm_frame or "auto",
                            gps=gps, names=[frame_key(i) for i in images])
    if suffix in (".geojson", ".csv"):
        if suffix == ".geojson":
            from .orthority import refuse_odm_shots
            refuse_odm_shots(p)
        if camera is None:
            raise InputError(f"orthority exterior parameters {str(p)!r} need their interior parameters: give the "
                             f"camera YAML (--camera)")
        from .orthority import read_orthority
        return read_orthority(p, camera, crs=crs)
    raise InputError(f"orientation file {str(p)!r}: unknown type; give 'name X Y Z omega phi kappa' lines (.txt), "
                     f"an OpenSfM/ODM reconstruction.json, a COLMAP model (folder, images.txt or images.bin) or "
                     f"orthority .geojson/.csv")
