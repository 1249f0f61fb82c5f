"""What every tool shares: the tool boundary (:mod:`.boundary`: options checked, errors translated,
progress), input and output-grid checks (:mod:`.checks`), the result objects (:mod:`.results`) and where
Dask tasks run (:mod:`.dask_cluster`)."""
