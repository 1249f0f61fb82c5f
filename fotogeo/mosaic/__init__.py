"""Orthophoto mosaics (arrays in, arrays out): seamlines (:mod:`.seams`), feathering and balancing (:mod:`.blend`)."""
