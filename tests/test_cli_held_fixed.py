"""The console and the QGIS log name the interior parameters held fixed on one line, each with why in short."""
from fotogeo.tools.triangulate.outputs import held_fixed_line


def test_one_line_with_the_correlation_and_partner_or_the_significance():
    line = held_fixed_line([
        {"parameter": "f", "multiple_correlation": 0.99972, "partner": "k2", "correlation": 0.256, "reason": "..."},
        {"parameter": "b3", "t": 1.2, "reason": "..."}])
    assert "\n" not in line
    assert line == ("held fixed (report.html says why): f (correlation 0.9997, most with k2 +0.26), "
                    "b3 (not significant, 1.2 sigma)")
