"""Orthophoto mosaics (arrays in, arrays out): each orthophoto on the seam grid over its own window
(:mod:`.patches`), seamlines (:mod:`.seams`), feathering and balancing (:mod:`.blend`)."""
