"""The correlation rule holds fixed an interior parameter the block cannot determine — correlated beyond
``max_correlation`` *and* imprecise — and leaves free one that is correlated but determined (a principal
point against the attitudes and the decentering terms, σ a fraction of a pixel)."""
from __future__ import annotations

from fotogeo.orientation.bundle import DETERMINED_PX, _to_fix


def _entry(name, rho, sigma_px, partner="f1.omega", image_sigma_px=0.1):
    return {"parameter": name, "multiple_correlation": rho, "partner": partner, "correlation": -0.9,
            "sigma": sigma_px, "sigma_px": sigma_px, "image_sigma_px": image_sigma_px}


def test_correlated_but_determined_stays_free():
    corr = [_entry("ppx", 0.9998, 0.10), _entry("ppy", 0.9999, 0.23), _entry("k1", 0.99, 0.02)]
    assert _to_fix(corr, 0.999) is None


def test_correlated_and_imprecise_is_held_fixed():
    corr = [_entry("f", 0.9999999, 220.0, "s1_01.Z0"), _entry("ppx", 0.9998, 0.10)]
    assert _to_fix(corr, 0.999)["parameter"] == "f"


def test_imprecise_but_not_correlated_stays_free():
    assert _to_fix([_entry("k1", 0.95, 5.0)], 0.999) is None


def test_a_poor_image_sigma_raises_the_bar():
    # observations of σ 2 px: a parameter known to 1.5 px is as well known as the points it is measured on
    assert _to_fix([_entry("ppx", 0.9998, 1.5, image_sigma_px=2.0)], 0.999) is None
    assert _to_fix([_entry("ppx", 0.9998, 1.5)], 0.999)["parameter"] == "ppx"
    assert DETERMINED_PX < 1.5


def test_a_decentering_term_known_to_most_of_a_pixel_is_held_fixed():
    # a 6-frame nadir flight: p1 correlated 0.9993, its σ moving the image points by 0.76 px
    assert _to_fix([_entry("p1", 0.9993, 0.76, "k1", image_sigma_px=0.2)], 0.999)["parameter"] == "p1"


def test_a_parameter_whose_inverse_diagonal_is_negative_is_held_fixed():
    """A singular system inverts, in its free direction, to a diagonal of any sign and size the BLAS at hand gives:
    negative, its σ was clipped to ~0 px, read as 'determined', and the parameter stayed free (on another machine
    the same parameter came out huge and was held fixed). Read by the σ's rule (NaN: undetermined), it is held
    fixed on every machine, its reason saying so."""
    from types import SimpleNamespace

    import numpy as np

    from fotogeo.orientation.bundle_robust import interior_correlations
    from fotogeo.orientation.bundle_rules import _fix_reason
    S = np.eye(7)
    S[6, 0] = S[0, 6] = 1.0  # f carries X0's information only: S singular
    Si = np.eye(7)
    Si[6, 6] = -3.0e9
    pb = SimpleNamespace(st=SimpleNamespace(n_frames=1, free_interior=[0]))
    post = SimpleNamespace(S=S, S_inv=Si, sigma0=1.0, interior_px=np.array([1.0]), image_sigma=0.3)
    corr = interior_correlations(pb, post, ["a"], ["f"])
    assert np.isnan(corr[0]["sigma_px"])
    assert _to_fix(corr, 0.999)["parameter"] == "f"
    assert "σ is undetermined" in _fix_reason(corr[0], 0.999)
