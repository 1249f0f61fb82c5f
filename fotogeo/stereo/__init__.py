"""Dense stereo of oriented images (array layer: numpy/OpenCV, no file I/O).

What it offers, in the order a surface model is made from oriented images:

* :mod:`~fotogeo.stereo.pairs` — which images to match: footprint overlap, base-to-height ratio and the angle
  between the views, a reason for every pair left out;
* :mod:`~fotogeo.stereo.rectify` — exact epipolar rectification of two frame cameras (Fusiello, Trucco & Verri
  2000) with the lens distortion removed through the cameras' own ground → image models;
* :mod:`~fotogeo.stereo.dense` — semi-global matching (Hirschmüller 2008, OpenCV's ``StereoSGBM``) with
  sub-pixel disparities, a left–right consistency check, speckle and uniqueness filters;
* :mod:`~fotogeo.stereo.refine` — optional least-squares refinement of those disparities (Gruen 1985);
* :mod:`~fotogeo.stereo.rays` — triangulation as the closest point of two rays, with the miss distance;
* :mod:`~fotogeo.stereo.fusion` — points of every pair binned onto one north-up grid, the median of the pairs,
  their count and spread, holes left as nodata (filled only on request, and marked).
"""
