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
