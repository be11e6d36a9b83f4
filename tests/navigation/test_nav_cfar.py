"""CFAR detectors on square-law Rayleigh (exponential) clutter with injected targets, along
azimuth (the default: the ring of beams) and along range (table 4.2's 50 + 5 cells a side)."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from navigation.cfar import CfarDetector, CfarWindowError, ring_side_sums, side_sums
from navigation.cfar_pfa import ca_factor, ca_pfa, goca_pfa, os_pfa, soca_pfa
from navigation.config import CfarConfig
from tests.navigation.nav_scenes import radar_noise_image

DETECTORS = ["ca", "soca", "goca", "os"]
BEAMS, CELLS = 72, 800  # a long-range radar image: 72 beams x 800 range cells
# Both axes: the default ring window, and table 4.2's window along range (fits 800 cells).
AXES = {"azimuth": {}, "range": {"axis": "range", "training_cells_per_side": 50}}


def measured_false_alarm_rate(detector: CfarDetector, images: int = 8) -> float:
    rates = [
        detector.detect(radar_noise_image(BEAMS, CELLS, 3.0, seed))[0].mean()
        for seed in range(images)
    ]
    return float(np.mean(rates))


@pytest.mark.parametrize("axis", AXES)
@pytest.mark.parametrize("kind", DETECTORS)
@pytest.mark.parametrize("pfa", [0.1, 0.01])
def test_measured_false_alarm_rate_matches_the_configured_one(kind, pfa, axis):
    """8 noise images = 460,800 cells; the binomial standard error alone is 0.5 % (0.1) and
    1.5 % (0.01) relative, cells sharing windows widen it a little: 8 % tolerance is > 5
    sigma yet catches a wrong factor (a 10 % factor error moves P_fa by 20 % or more)."""
    config = CfarConfig(detector=kind, false_alarm_rate=pfa, **AXES[axis])
    assert measured_false_alarm_rate(CfarDetector.from_config(config)) == pytest.approx(
        pfa, rel=0.08
    )


@pytest.mark.parametrize("kind", DETECTORS)
def test_false_alarm_rate_holds_at_the_row_ends(kind):
    """Along range, edge cells use one side only, with their own factor."""
    detector = CfarDetector.from_config(CfarConfig(detector=kind, **AXES["range"]))
    edges = [
        np.concatenate([hits[:, :55], hits[:, -55:]], axis=1).mean()
        for hits in (detector.detect(radar_noise_image(BEAMS, CELLS, 1.0, s))[0] for s in range(8))
    ]
    assert np.mean(edges) == pytest.approx(0.1, rel=0.1)  # 63,360 cells, sigma 1.2 %


@pytest.mark.parametrize("axis", AXES)
@pytest.mark.parametrize("kind", DETECTORS)
def test_injected_targets_are_detected(kind, axis):
    rng = np.random.default_rng(7)
    image = radar_noise_image(BEAMS, CELLS, 1.0, seed=11)
    beams = rng.integers(0, BEAMS, 40)
    cells = rng.integers(0, CELLS, 40)
    image[beams, cells] = 100.0  # thesis 4.1: targets given a reflection of about 100
    detector = CfarDetector.from_config(
        CfarConfig(detector=kind, false_alarm_rate=1e-3, **AXES[axis])
    )
    hits, threshold = detector.detect(image)
    assert hits[beams, cells].all()
    assert np.all(threshold[beams, cells] < 100.0)
    assert hits.mean() < 0.01


def test_threshold_scales_with_the_noise_level():
    detector = CfarDetector.from_config(CfarConfig())
    image = radar_noise_image(72, 30, 1.0, seed=2)
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


def test_ring_side_sums_match_a_direct_sum_around_the_ring():
    image = radar_noise_image(10, 3, seed=6)
    lead, lag = ring_side_sums(image, 3, 1)
    for beam in (0, 1, 5, 9):
        lead_beams = [(beam - 1 - k) % 10 for k in range(1, 4)]
        lag_beams = [(beam + 1 + k) % 10 for k in range(1, 4)]
        np.testing.assert_allclose(lead[beam], image[lead_beams].sum(axis=0), rtol=1e-6)
        np.testing.assert_allclose(lag[beam], image[lag_beams].sum(axis=0), rtol=1e-6)


def test_the_azimuth_window_wraps_around_the_ring():
    """Beam 0's leading training cells are the last beams: a target in beam 0 is detected,
    and one in beam 71 raises beam 1's threshold as much as beam 69's (each is 2 beams off)."""
    detector = CfarDetector.from_config(CfarConfig(detector="ca", guard_cells_per_side=1))
    image = radar_noise_image(72, 25, 1.0, seed=3)
    image[0, 12] = 500.0
    hits, threshold = detector.detect(image)
    assert hits[0, 12] and np.isfinite(threshold).all()
    flat = np.ones((72, 25), np.float32)
    flat[71, 5] = 100.0
    raised = detector.threshold(flat)[:, 5]
    assert raised[1] == pytest.approx(raised[69]) and raised[1] > raised[35]


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
    assert CfarDetector.from_config(CfarConfig(detector="os")).rank == 45
    assert CfarDetector.from_config(CfarConfig(detector="os", os_rank=10)).rank == 10


@pytest.mark.parametrize(
    ("config", "shape", "names"),
    [
        # table 4.2's window along range on the simulator's 25 range cells (thesis table 4.1)
        ({"axis": "range", "training_cells_per_side": 50}, (72, 25), "111 range cells"),
        # the default ring window on a radar of 10 deg beams
        ({}, (36, 25), "71 beams"),
    ],
)
def test_a_window_that_does_not_fit_is_an_error_naming_the_fields(config, shape, names):
    detector = CfarDetector.from_config(CfarConfig(**config))
    with pytest.raises(CfarWindowError, match=r"cfar\.training_cells_per_side") as error:
        detector.detect(np.ones(shape, np.float32))
    assert names in str(error.value) and "cfar.guard_cells_per_side" in str(error.value)


def test_the_default_window_fits_the_default_radar_and_keeps_the_false_alarm_rate():
    """72 beams x 25 cells (thesis table 4.1); 8 x 10 sweeps = 144,000 cells."""
    detector = CfarDetector.from_config(CfarConfig())
    assert (detector.n_side, detector.n_guard, detector.span) == (30, 5, 71)
    rates = [detector.detect(radar_noise_image(72, 25, 1.0, s))[0].mean() for s in range(80)]
    assert np.mean(rates) == pytest.approx(0.1, rel=0.08)


def test_os_rank_outside_the_window_is_refused():
    with pytest.raises(pydantic.ValidationError, match="os_rank"):
        CfarConfig(detector="os", os_rank=61)
