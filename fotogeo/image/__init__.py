"""Image radiometry on arrays: PCA band fusion with a robust stretch (:mod:`.fusion`) and contrast for matching
(:mod:`.contrast`)."""
