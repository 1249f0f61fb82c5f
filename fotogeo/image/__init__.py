"""Image radiometry on arrays: PCA band fusion with a robust stretch (:mod:`.fusion`), contrast for matching
(:mod:`.contrast`), and one image's bands combined to match another's fusion (:mod:`.band_match`)."""
