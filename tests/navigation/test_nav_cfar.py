"""CFAR detectors on square-law Rayleigh (exponential) clutter with injected targets."""

from __future__ import annotations

import numpy as np
import pytest
from nav_scenes import radar_noise_image

from navigation.cfar import CfarDetector, side_sums
from navigation.cfar_pfa import ca_factor, ca_pfa, goca_pfa, os_pfa, soca_pfa
from navigation.config import CfarConfig

DETECTORS = ["ca", "soca", "goca", "os"]
BEAMS, CELLS = 72, 800  # the realistic radar image: 72 beams x 800 range cells


def measured_false_alarm_rate(detector: CfarDetector, images: int = 8) -> float:
    rates = [
        detector.detect(radar_noise_image(BEAMS, CELLS, 3.0, seed))[0].mean()
        for seed in range(images)
    ]
    return float(np.mean(rates))


@pytest.mark.parametrize("kind", DETECTORS)
@pytest.mark.parametrize("pfa", [0.1, 0.01])
def test_measured_false_alarm_rate_matches_the_configured_one(kind, pfa):
    """8 noise images = 460,800 cells; the binomial standard error alone is 0.5 % (0.1) and
    1.5 % (0.01) relative, cells sharing windows widen it a little: 8 % tolerance is > 5
    sigma yet catches a wrong factor (a 10 % factor error moves P_fa by 20 % or more)."""
    detector = CfarDetector.from_config(CfarConfig(detector=kind, false_alarm_rate=pfa))
    assert measured_false_alarm_rate(detector) == pytest.approx(pfa, rel=0.08)


@pytest.mark.parametrize("kind", DETECTORS)
def test_false_alarm_rate_holds_at_the_row_ends(kind):
    """Edge cells use one side only, with their own factor."""
    detector = CfarDetector.from_config(CfarConfig(detector=kind))
    edges = [
        np.concatenate([hits[:, :55], hits[:, -55:]], axis=1).mean()
        for hits in (detector.detect(radar_noise_image(BEAMS, CELLS, 1.0, s))[0] for s in range(8))
    ]
    assert np.mean(edges) == pytest.approx(0.1, rel=0.1)  # 63,360 cells, sigma 1.2 %


@pytest.mark.parametrize("kind", DETECTORS)
def test_injected_targets_are_detected(kind):
    rng = np.random.default_rng(7)
    image = radar_noise_image(BEAMS, CELLS, 1.0, seed=11)
    beams = rng.integers(0, BEAMS, 40)
    cells = rng.integers(0, CELLS, 40)
    image[beams, cells] = 100.0  # thesis 4.1: targets given a reflection of about 100
    detector = CfarDetector.from_config(CfarConfig(detector=kind, false_alarm_rate=1e-3))
    hits, threshold = detector.detect(image)
    assert hits[beams, cells].all()
    assert np.all(threshold[beams, cells] < 100.0)
    assert hits.mean() < 0.01


def test_threshold_scales_with_the_noise_level():
    detector = CfarDetector.from_config(CfarConfig())
    image = radar_noise_image(4, 300, 1.0, seed=2)
    np.testing.assert_allclose(
        detector.threshold(image * 50.0), detector.threshold(image) * 50.0, rtol=1e-5
    )


def test_side_sums_match_a_direct_sum():
    image = radar_noise_image(3, 40, seed=5)
    lead, lag = side_sums(image, 4, 2)
    for i in (6, 20, 33):
        assert lead[1, i] == pytest.approx(image[1, i - 6 : i - 2].sum(), rel=1e-6)
        assert lag[1, i] == pytest.approx(image[1, i + 3 : i + 7].sum(), rel=1e-6)
    assert np.isnan(lead[:, :6]).all() and np.isnan(lag[:, -6:]).all()


def test_short_rows_never_detect():
    detector = CfarDetector.from_config(CfarConfig())
    hits, threshold = detector.detect(np.full((2, 50), 1e6, np.float32))
    assert not hits.any() and np.isinf(threshold).all()


def test_pfa_expressions_agree_with_monte_carlo():
    """Independent check of the closed forms with a direct simulation of one CUT."""
    rng = np.random.default_rng(3)
    n, trials = 8, 400_000
    lead = rng.exponential(size=(trials, n))
    lag = rng.exponential(size=(trials, n))
    cut = rng.exponential(size=trials)
    a = 3.0
    side_lead, side_lag = lead.mean(1), lag.mean(1)
    ref = np.sort(np.concatenate([lead, lag], 1), axis=1)
    cases = [
        (ca_pfa(a, 2 * n), cut > a * 0.5 * (side_lead + side_lag)),
        (soca_pfa(a, n), cut > a * np.minimum(side_lead, side_lag)),
        (goca_pfa(a, n), cut > a * np.maximum(side_lead, side_lag)),
        (os_pfa(a, 2 * n, 12), cut > a * ref[:, 11]),
    ]
    for expected, hits in cases:
        assert hits.mean() == pytest.approx(expected, rel=0.03)


def test_ca_factor_inverts_ca_pfa():
    assert ca_pfa(ca_factor(0.1, 100), 100) == pytest.approx(0.1)
    assert ca_pfa(ca_factor(1e-6, 100), 100) == pytest.approx(1e-6)


def test_os_rank_defaults_to_three_quarters():
    assert CfarDetector.from_config(CfarConfig(detector="os")).rank == 75
    assert CfarDetector.from_config(CfarConfig(detector="os", os_rank=10)).rank == 10


def test_window_fits_a_short_row(caplog):
    """The simulator's default radar (25 cells of 4 m) is too short for 2 x 50 cells."""
    detector = CfarDetector.from_config(CfarConfig(detector="os"), num_cells=25)
    assert detector.n_side == 7 and "only 7 training cells" in caplog.text
    assert detector.rank <= 14
    image = radar_noise_image(72, 25, 1.0, seed=1)
    image[10, 12] = 500.0
    hits, threshold = detector.detect(image)
    assert hits[10, 12] and np.isfinite(threshold).all()
    with pytest.raises(ValueError, match="guard"):
        CfarDetector.from_config(CfarConfig(), num_cells=11)


def test_fitted_window_keeps_the_false_alarm_rate():
    detector = CfarDetector.from_config(CfarConfig(), num_cells=25)
    rates = [detector.detect(radar_noise_image(720, 25, 1.0, s))[0].mean() for s in range(8)]
    assert np.mean(rates) == pytest.approx(0.1, rel=0.08)  # 144,000 cells
