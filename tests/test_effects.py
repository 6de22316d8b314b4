"""Each noise effect's own fingerprint (Eq. 5–9 and the others), with tolerances from the sample size.

Tolerances: a mean over ``n`` independent pixels is held to ``Z`` standard errors, the standard
error estimated from the same pixels (``std / √n``); with ``Z = 5`` a correct model fails with
probability below 1e-6, while every wrong model named in the tests is off by far more.
"""

import math

import numpy as np
import pytest
from scipy import stats

from spikeref.oracles import effects as oracle
from spikeref.simulate import effects as fx
from spikeref.simulate.simulator import Simulation, simulate
from tests.scene_doubles import Flat, scene

Z = 5.0


def counts_per_pixel(spikes):
    return spikes.reshape(spikes.shape[0], -1).sum(axis=0).astype(np.float64)


def assert_mean(samples, expected, extra=0.0):
    """Mean of independent per-pixel samples equals ``expected`` within ``Z`` standard errors (+ a known bias bound)."""
    se = samples.std(ddof=1) / math.sqrt(samples.size)
    assert abs(samples.mean() - expected) <= Z * se + extra, (samples.mean(), expected, se)
    return se


DARK = Flat(64, 64, rgb=(0.0, 0.0, 0.0))


# ------------------------------------------------------------------------- parsing
def test_parse_effects_names_the_bad_field():
    with pytest.raises(ValueError, match="unknown effect 'moon_noise'"):
        fx.parse_effects({"moon_noise": {}})
    with pytest.raises(ValueError, match="dark_current.gama"):
        fx.parse_effects({"dark_current": {"gama": 1}})
    with pytest.raises(ValueError, match="inherent_noise.mu"):
        fx.parse_effects({"inherent_noise": {"mu": 0.5}})
    with pytest.raises(ValueError, match="shot_noise.photons_per_threshold"):
        fx.parse_effects({"shot_noise": {"photons_per_threshold": float("nan")}})
    with pytest.raises(ValueError, match="threshold_fpn.sigma"):
        fx.parse_effects({"threshold_fpn": {"sigma": -0.1}})
    with pytest.raises(ValueError, match="hot_pixels.rate"):
        fx.parse_effects({"hot_pixels": {"rate": 2}})
    with pytest.raises(TypeError):
        fx.parse_effects("dark_current")
    assert set(fx.parse_effects(["random_phase", "dark_current"])) == {"random_phase", "dark_current"}
    assert fx.parse_effects({"dark_current": {"gamma": 0.5}})["dark_current"].gamma == 0.5


def test_unlisted_stage_costs_nothing(monkeypatch):
    """With no effects listed, no effect function runs and no random generator is made."""

    def boom(*a, **k):
        raise AssertionError("an effect ran although the scene does not list it")

    for name in ("fpn_thresholds", "initial_phase", "hot_pixel_charge", "add_shot_noise", "add_dark_current",
                 "InherentNoiseProcess"):
        monkeypatch.setattr(fx, name, boom)
    import importlib

    sim_mod = importlib.import_module("spikeref.simulate.simulator")  # sr.simulate is the function

    monkeypatch.setattr(sim_mod, "_rng", boom)
    out = simulate(scene(Flat(8, 8), planes=40), seed=0)
    assert out.spikes.sum() > 0


# ------------------------------------------------------------------------- Eq. 6
def test_eq6_dark_current_expected_count():
    alpha, gamma, threshold, planes = 0.25, 0.02, 1.0, 4000
    sc = scene(DARK, planes=planes, effects={"random_phase": {}, "dark_current": {"gamma": gamma}},
               alpha=alpha, threshold=threshold)
    counts = counts_per_pixel(simulate(sc, seed=1).spikes)
    expected = fx.dark_expected_count(alpha, gamma, planes, threshold)
    assert expected == oracle.dark_expected_count_oracle(alpha, gamma, planes, threshold) == 20.0
    assert_mean(counts, expected)
    # the fingerprint is specific: γ W (one spike per dark photon) would be 4× higher
    assert abs(counts.mean() - gamma * planes) > 10 * counts.std() / 64


def test_eq5_dark_photons_are_poisson():
    """With α = E_th every dark photon is a spike: counts per window are Poisson(γW) (Eq. 5)."""
    gamma, planes = 0.01, 3000
    sc = scene(DARK, planes=planes, effects={"dark_current": {"gamma": gamma}})
    spikes = simulate(sc, seed=2).spikes
    counts = counts_per_pixel(spikes)
    assert_mean(counts, gamma * planes)
    # Poisson: variance = mean; the variance of a sample variance of n Poisson(λ) values is ≈ (2λ² + λ)/n
    lam, n = gamma * planes, counts.size
    assert abs(counts.var(ddof=1) - lam) <= Z * math.sqrt((2 * lam**2 + lam) / n)


# ------------------------------------------------------------------------- Eq. 8
@pytest.mark.parametrize("mu,sigma", [(2000.0, 200.0), (100.0, 30.0), (10.0, 3.0), (3.0, 2.0), (1.2, 0.5)])
def test_eq8_rates_match_their_oracles(mu, sigma):
    assert fx.inherent_rate_paper(mu, sigma) == pytest.approx(oracle.inherent_rate_paper_oracle(mu, sigma), rel=1e-8)
    assert fx.inherent_rate_exact(mu, sigma) == pytest.approx(oracle.inherent_rate_exact_oracle(mu, sigma), rel=1e-12)


def test_eq8_paper_approximation_error_is_second_order():
    """``E[1/T] ≈ 1/E[T](1 + σ²/μ²)`` for narrow intervals: the paper's C_i is high by about σ²/μ²."""
    for mu, sigma in [(2000.0, 200.0), (500.0, 25.0), (100.0, 10.0)]:
        ratio = fx.inherent_rate_paper(mu, sigma) / fx.inherent_rate_exact(mu, sigma) - 1
        assert ratio == pytest.approx((sigma / mu) ** 2, rel=0.1)


@pytest.mark.parametrize("mu,sigma", [(40.0, 12.0), (6.0, 3.0)])
def test_eq8_inherent_noise_count(mu, sigma):
    planes = 4000
    sc = scene(DARK, planes=planes, effects={"inherent_noise": {"mu": mu, "sigma": sigma}})
    counts = counts_per_pixel(simulate(sc, seed=3).spikes)
    se = assert_mean(counts, fx.inherent_rate_exact(mu, sigma) * planes)
    # Eq. 8's C_i W is off by O(σ²/μ²), many standard errors here: the paper's value is an approximation
    paper = fx.inherent_rate_paper(mu, sigma) * planes
    assert abs(counts.mean() - paper) > Z * se


def test_inherent_noise_fraction_of_pixels():
    sc = scene(DARK, planes=200, effects={"inherent_noise": {"mu": 20.0, "sigma": 2.0, "fraction": 0.25}})
    counts = counts_per_pixel(simulate(sc, seed=4).spikes)
    affected = (counts > 0).mean()
    n = counts.size
    assert abs(affected - 0.25) <= Z * math.sqrt(0.25 * 0.75 / n)
    assert counts[counts > 0].min() >= 8  # every affected pixel fires at its rhythm


def test_inherent_first_spike_is_stationary():
    """Started mid-stream, the count in a short window is already W / E[T] (no start-up transient)."""
    rng = np.random.default_rng(5)
    mu, sigma = 30.0, 6.0
    first = fx.draw_first_inherent(rng, mu, sigma, 200_000)
    # stationary forward recurrence: P(first < W) = W / E[T] for W ≤ min interval
    w = 5
    p = (first < w).mean()
    expected = w * fx.inherent_rate_exact(mu, sigma)
    assert abs(p - expected) <= Z * math.sqrt(expected * (1 - expected) / first.size)


# ------------------------------------------------------------------------- Eq. 9
def test_eq9_diffuse_plus_inherent():
    alpha, gamma, mu, sigma, planes = 0.5, 0.01, 80.0, 16.0, 4000
    sc = scene(DARK, planes=planes, alpha=alpha,
               effects={"random_phase": {}, "dark_current": {"gamma": gamma},
                        "inherent_noise": {"mu": mu, "sigma": sigma}})
    counts = counts_per_pixel(simulate(sc, seed=6).spikes)
    r_d = alpha * gamma
    r_i = fx.inherent_rate_exact(mu, sigma)
    # Eq. 9 adds the rates; a diffuse and an inherent spike in one readout are read out once (−r_d·r_i)
    assert_mean(counts / planes, fx.noise_fraction(alpha, gamma, 1.0, mu, sigma, exact=True) - r_d * r_i)
    assert fx.noise_fraction(alpha, gamma, 1.0, mu, sigma) == pytest.approx(
        oracle.noise_fraction_oracle(alpha, gamma, 1.0, mu, sigma), rel=1e-8)


# ------------------------------------------------------------------------- shot noise
def test_shot_noise_variance_over_mean():
    n_th, rate, planes = 50.0, 0.2, 4000
    sc = scene(Flat(64, 64, rgb=(rate, rate, rate)), planes=planes,
               effects={"random_phase": {}, "shot_noise": {"photons_per_threshold": n_th}})
    counts = counts_per_pixel(simulate(sc, seed=7).spikes)
    assert_mean(counts, rate * planes)
    # N = ⌊U + X⌋ with X = photons / n_th: Var N = Var X + E[f(1 − f)] = rate·W/n_th + 1/6 (f uniform)
    expected_var = rate * planes / n_th + 1 / 6
    n = counts.size
    assert abs(counts.var(ddof=1) - expected_var) <= Z * expected_var * math.sqrt(2 / (n - 1))
    # without shot noise the count only varies by the phase: at most 1/4
    quiet = counts_per_pixel(simulate(scene(sc.content, planes=planes, effects={"random_phase": {}}), seed=7).spikes)
    assert quiet.var() <= 0.25 + 1e-12


# ------------------------------------------------------------------------- FPN
def test_threshold_fpn_is_a_fixed_pattern():
    sigma, rate, planes = 0.05, 0.3, 4000
    sc = scene(Flat(32, 32, rgb=(rate, rate, rate)), planes=planes,
               effects={"random_phase": {}, "threshold_fpn": {"sigma": sigma}})
    sim = Simulation(sc, seed=8)
    thresholds = sim.thresholds.copy()
    spikes = sim.run(planes).spikes
    half = planes // 2
    a = counts_per_pixel(spikes[:half]) / half
    b = counts_per_pixel(spikes[half:]) / half
    # each pixel fires at rate / E_th,x, to the quantisation of its count (±1 spike per half)
    assert np.abs(a * thresholds.ravel() - rate).max() <= 1.0 / half * thresholds.max() + 1e-12
    # the pattern repeats across windows, and its spread is σ (sample-size tolerance on a std)
    assert np.corrcoef(a, b)[0, 1] > 0.99
    rel = thresholds.ravel() / 1.0 - 1
    assert abs(rel.std(ddof=1) - sigma) <= Z * sigma / math.sqrt(2 * (rel.size - 1))
    # the same seed gives the same pattern; another seed another one
    assert np.array_equal(Simulation(sc, seed=8).thresholds, thresholds)
    assert not np.array_equal(Simulation(sc, seed=9).thresholds, thresholds)


# ------------------------------------------------------------------------- random phase
def test_random_phase_first_spikes_uniform():
    k = 8
    sc = scene(Flat(64, 64, rgb=(1 / k,) * 3), planes=k, effects={"random_phase": {}})
    spikes = simulate(sc, seed=10).spikes.reshape(k, -1)
    first = spikes.argmax(axis=0)
    assert spikes.sum(axis=0).min() == 1  # every pixel fires exactly once in one period
    observed = np.bincount(first, minlength=k)
    chi2 = ((observed - first.size / k) ** 2 / (first.size / k)).sum()
    assert chi2 < stats.chi2.ppf(1 - 1e-6, k - 1)
    # without the effect every pixel starts empty and fires first at readout k − 1
    plain = simulate(scene(sc.content, planes=k), seed=10).spikes.reshape(k, -1)
    assert np.all(plain.argmax(axis=0) == k - 1)


# ------------------------------------------------------------------------- hot pixels
def test_hot_pixels_with_a_range_of_rates():
    """``rate_max``: each hot pixel's rate is drawn from U[rate, rate_max] after the pixels are chosen, so the same
    seed picks the same pixels as without it; in the dark each fires at its drawn rate (5 σ bounds)."""
    sc = scene(DARK, planes=400, effects={"hot_pixels": {"fraction": 0.02, "rate": 0.3, "rate_max": 0.9}})
    sim = Simulation(sc, seed=5)
    hot = sim.hot > 0
    drawn = sim.hot[hot] / sc.camera.threshold
    assert abs(hot.sum() - 0.02 * hot.size) < 5 * math.sqrt(0.02 * 0.98 * hot.size)
    assert drawn.min() >= 0.3 and drawn.max() <= 0.9
    assert abs(drawn.mean() - 0.6) < 5 * 0.6 / math.sqrt(12 * hot.sum())  # U[0.3, 0.9]: mean 0.6, sd 0.6/√12
    assert stats.kstest((drawn - 0.3) / 0.6, "uniform").pvalue > 1e-4
    rate = counts_per_pixel(simulate(sc, seed=5).spikes).reshape(hot.shape) / 400
    np.testing.assert_allclose(rate[hot], drawn, atol=1 / 400 + 1e-9)  # integrate-and-fire at a constant charge
    assert rate[~hot].max() == 0
    plain = Simulation(scene(DARK, planes=400, effects={"hot_pixels": {"fraction": 0.02, "rate": 0.3}}), seed=5)
    np.testing.assert_array_equal(plain.hot > 0, hot)
    assert np.all(plain.hot[hot] == 0.3 * sc.camera.threshold)
    with pytest.raises(ValueError, match="hot_pixels.rate_max must lie in"):
        fx.parse_effects({"hot_pixels": {"rate": 0.5, "rate_max": 0.4}})


def test_hot_pixels():
    fraction, rate, planes = 0.02, 0.25, 400
    sc = scene(DARK, planes=planes, effects={"hot_pixels": {"fraction": fraction, "rate": rate}})
    counts = counts_per_pixel(simulate(sc, seed=11).spikes)
    hot = counts > 0
    n = counts.size
    assert abs(hot.mean() - fraction) <= Z * math.sqrt(fraction * (1 - fraction) / n)
    assert np.all(counts[hot] == rate * planes)  # a hot pixel fires at exactly its rate, in the dark
