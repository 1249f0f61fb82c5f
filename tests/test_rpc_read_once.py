"""``ortho --rpc`` and ``dsm --rpc`` read each image's RPC once: the map CRS, the models, the cut-out check
(:mod:`fotogeo.io.rpc_place`) and the report's RPC sources take the :class:`~fotogeo.io.rpc_image.ImageRpc` read
(the file beside the image was read again by each: 5 reads for ortho's two ventoux images, 6 for dsm's pair)."""
from __future__ import annotations

import collections
import warnings

import pytest

pytestmark = [pytest.mark.data]


@pytest.fixture
def reads(monkeypatch):
    """Counts of the RPC files read (:func:`fotogeo.io.rpc.read_rpc`) and of the rasters' RPC metadata read, per
    image name, wherever :mod:`fotogeo.io.rpc_image` and :mod:`fotogeo.io.rpc_place` read them."""
    import fotogeo.io.rpc_image as ri
    import fotogeo.io.rpc_place as rpl
    counts = collections.Counter()

    def counted(f, what):
        def g(path, *a, **k):
            counts[(what, str(path).rsplit("/", 1)[-1])] += 1
            return f(path, *a, **k)
        return g
    for mod in (ri, rpl):
        monkeypatch.setattr(mod, "read_rpc", counted(mod.read_rpc, "file"))
    monkeypatch.setattr(ri, "rpc_from_raster", counted(ri.rpc_from_raster, "metadata"))
    return counts


def _ventoux(data_dir):
    v = data_dir / "rpc" / "ventoux"
    return [v / "left_image.tif", v / "right_image.tif"]


def test_ortho_reads_each_rpc_once(data_dir, tmp_path, reads):
    from fotogeo.tools.ortho import ortho
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ortho(_ventoux(data_dir), tmp_path / "o", rpc=True, height=500.0, resolution=20.0)
    assert dict(reads) == {("metadata", "left_image.tif"): 1, ("file", "left_image.geom"): 1,
                           ("metadata", "right_image.tif"): 1, ("file", "right_image.geom"): 1}


def test_dsm_reads_each_rpc_once(data_dir, tmp_path, reads):
    from fotogeo.tools.dsm import dsm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dsm(_ventoux(data_dir), tmp_path / "dsm.tif", rpc=True)
    assert dict(reads) == {("metadata", "left_image.tif"): 1, ("file", "left_image.geom"): 1,
                           ("metadata", "right_image.tif"): 1, ("file", "right_image.geom"): 1}
