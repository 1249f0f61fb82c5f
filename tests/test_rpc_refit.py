"""Refit RFMs to real vendor RPCs (rpcm test files) sampled on 3-D grids."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fotogeo.errors import InputError
from fotogeo.models import MODELS, IllPosedWarning
from fotogeo.pixels import from_centre
from fotogeo.orientation.rpc import Rpc
from fotogeo.io.rpc import read_rpc, read_rpc_text

FILES = ["rpc_IKONOS.txt", "rpc_PLANET_L1A.txt", "rpc_PLANET_L1B.txt", "rpc_PLEIADES.xml", "rpc_SPOT6.xml",
         "rpc_WV2.xml", "20191015_073816_ssc1d3_0011_basic_l1a_panchromatic_dn_RPC.TXT"]


def sample(rpc: Rpc, n: int, rng):
    """Ground points inside the image footprint: random pixels over the image (corner
    convention), heights over ±HEIGHT_SCALE/2, lifted to (lon, lat, h) by inverting the vendor
    RPC; exact pairs."""
    px = np.column_stack([rpc.samp_off + 0.5 + rpc.samp_scale * rng.uniform(-1, 1, n),
                          rpc.line_off + 0.5 + rpc.line_scale * rng.uniform(-1, 1, n)])
    h = rpc.height_off + rpc.height_scale * rng.uniform(-0.5, 0.5, n)
    ground = rpc.to_model().inverse(px, h)
    return ground, px


@pytest.mark.data
def test_reader_and_model_agree(data_dir):
    rpc = read_rpc_text(data_dir / "rpc" / "rpcm" / "rpc_IKONOS.txt")
    assert rpc.line_off == 5124.0 and rpc.long_off == -56.1722 and rpc.samp_den[0] == 1.0
    # the vendor's own offsets map to the centre of its normalised space
    assert np.allclose(rpc.project(rpc.long_off, rpc.lat_off, rpc.height_off),
                       [[rpc.samp_off + rpc.samp_scale * rpc.samp_num[0],
                         rpc.line_off + rpc.line_scale * rpc.line_num[0]]])
    g, px = sample(rpc, 50, np.random.default_rng(0))
    assert np.abs(from_centre(rpc.project(*g.T)) - px).max() < 1e-6  # RPC: centre convention
    assert np.abs(rpc.to_model().forward(g) - px).max() < 1e-6
    with pytest.raises(InputError, match="unsupported"):
        read_rpc(data_dir / "rpc" / "rpcm" / "rpc_unsupported.xml")


@pytest.mark.data
@pytest.mark.parametrize("name", FILES)
def test_refit_vendor_rpc(data_dir, name):
    rpc = read_rpc(data_dir / "rpc" / "rpcm" / name)
    rng = np.random.default_rng(42)
    g, px = sample(rpc, 500, rng)
    fit_g, fit_px, chk_g, chk_px = g[:200], px[:200], g[200:], px[200:]
    m = MODELS["rfm"].estimate(fit_g, fit_px)
    rms = np.sqrt(np.mean((m.forward(chk_g) - chk_px) ** 2, axis=0))
    assert (rms < 0.01).all(), rms
    noisy = fit_px + rng.normal(0.0, 0.3, fit_px.shape)
    mn = MODELS["rfm"].estimate(fit_g, noisy)
    rms_n = np.sqrt(np.mean((mn.forward(chk_g) - chk_px) ** 2, axis=0))
    assert (rms_n <= 0.3).all(), rms_n
    # a first-order (DLT) fit cannot represent these sensors: the cubic terms matter
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IllPosedWarning)
        dlt = MODELS["dlt"].estimate(fit_g, fit_px)
    assert np.sqrt(np.mean((dlt.forward(chk_g) - chk_px) ** 2)) > 5 * np.sqrt(np.mean(rms ** 2))
