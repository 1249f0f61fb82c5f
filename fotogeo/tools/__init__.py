"""The tools: paths in, paths out, one package per capability (DESIGN.md, "Architecture").

* :mod:`.register` — registration to a georeferenced reference, matching, band fusion, batches;
* :mod:`.coreg` — area-based co-registration of two dates;
* :mod:`.orient` — orientation models from GCPs, model comparison, RPC bias, rectification;
* :mod:`.gcp` — the GCP picker's engine;
* :mod:`.points` — GCP transfer, target measurement, ``.points`` files;
* :mod:`.interior` — interior orientation of film scans;
* :mod:`.triangulate` — aerial triangulation of a block;
* :mod:`.ortho` — orthophotos and mosaics;
* :mod:`.dsm` — surface models and point clouds by dense matching;
* :mod:`.demo` — the embedded default run;
* :mod:`.common` — what they share: the tool boundary, checks, result objects, the Dask cluster.
"""
