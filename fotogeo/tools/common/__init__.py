"""What every tool shares: the tool boundary (:mod:`.boundary`: options checked, errors translated,
progress), input and output-grid checks (:mod:`.checks`), the result objects (:mod:`.results`), where
Dask tasks run (:mod:`.dask_cluster`), the legend class of a GCP in every layer (:mod:`.gcp_style`) and the
capability packages' names loaded on first use (:mod:`.lazy`)."""
