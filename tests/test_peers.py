"""Classical peer denoisers (spikeref.denoise.peers): shapes, that each one denoises binomial
spike rates, the documented spike-aware σ, flat planes, argument errors and the one-line
message when an optional package is missing.  bm3d / scikit-image tests skip without them."""

import sys

import numpy as np
import pytest
from scipy import ndimage

from spikeref.denoise import PEERS, PeerDenoiser
from spikeref.denoise.peers import peer_available

W = 10

# Smallest MSE reduction (dB, 10·log10(MSE_noisy / MSE_denoised)) each peer must reach on the
# 64 × 96 plane below.  Measured with blind σ over 8 seeds of truth and noise: worst 15.5 dB (bm3d),
# 14.8 dB (nlm), 10.5 dB (gaussian σ = 1 px; theory for white noise 10·log10(4π) = 11 dB); spike σ:
# worst 15.2 dB (bm3d), 14.2 dB (nlm).  The pins sit about 2 dB (1.5 for gaussian) under the worst.
MIN_GAIN_DB = {"bm3d": 13.0, "nlm": 12.0, "gaussian": 9.0}


def _truth(seed=0, shape=(64, 96)):
    """A smooth firing probability in [0.1, 0.6]."""
    g = ndimage.gaussian_filter(np.random.default_rng(seed).standard_normal(shape), 6.0, mode="reflect")
    g = (g - g.min()) / (g.max() - g.min())
    return 0.1 + 0.5 * g


def _rates(p, seed=100):
    """Eq. 4 rates of binomial counts over W readouts, float32."""
    return (np.random.default_rng(seed).binomial(W, p) / W).astype(np.float32)


def _needs(method, sigma="blind"):
    """Skip unless the packages of the ``peers`` extra that ``method`` with ``sigma`` imports are here."""
    if method == "bm3d":
        pytest.importorskip("bm3d")
    if method in ("bm3d", "nlm"):
        pytest.importorskip("skimage")
        if sigma == "blind":   # scikit-image's estimate_sigma imports PyWavelets when called
            pytest.importorskip("pywt")


@pytest.mark.parametrize("method", PEERS)
def test_four_planes_in_four_float32_finite_planes_out(method):
    _needs(method)
    planes = np.stack([_rates(_truth(s, (24, 32)), 100 + s) for s in range(4)])
    out = PeerDenoiser(method)(planes)
    assert out.shape == (4, 24, 32) and out.dtype == np.float32 and np.all(np.isfinite(out))
    # each plane on its own: denoising one plane alone gives the same plane
    np.testing.assert_allclose(PeerDenoiser(method)(planes[2].astype(np.float64)), out[2], atol=1e-6)


@pytest.mark.parametrize("method,sigma", [("bm3d", "blind"), ("bm3d", "spike"), ("nlm", "blind"),
                                          ("nlm", "spike"), ("gaussian", "blind")])
def test_each_peer_lowers_the_mse_of_binomial_rates(method, sigma):
    _needs(method, sigma)
    p = _truth()
    rates = _rates(p)
    out = PeerDenoiser(method, sigma=sigma)(rates, window=W)
    gain_db = 10 * np.log10(np.mean((rates - p) ** 2) / np.mean((out - p) ** 2))
    assert gain_db >= MIN_GAIN_DB[method], (method, sigma, gain_db)


def test_spike_sigma_is_the_documented_binomial_formula():
    plane = np.array([[0.0, 0.2, 0.5], [1.0, 1.3, -0.1]], np.float32)
    # p̂ = clip → [0, .2, .5, 1, 1, 0]; p̂(1 − p̂) = [0, .16, .25, 0, 0, 0]; mean = 0.41 / 6; σ = sqrt(mean / W)
    expected = np.sqrt(0.41 / 6 / W)
    got = PeerDenoiser("nlm", sigma="spike").plane_sigma(plane, window=W)
    assert got == pytest.approx(expected, rel=1e-6)
    assert got == pytest.approx(0.0826640, rel=1e-5)


def test_spike_sigma_reaches_the_library_call(monkeypatch):
    skimage_restoration = pytest.importorskip("skimage.restoration")
    seen = {}

    def fake_nlm(plane, **kw):
        seen.update(kw)
        return plane

    monkeypatch.setattr(skimage_restoration, "denoise_nl_means", fake_nlm)
    rates = _rates(_truth(shape=(16, 16)))
    PeerDenoiser("nlm", sigma="spike")(rates, window=W)
    p = rates.astype(np.float64)
    sigma = np.sqrt(np.mean(p * (1 - p)) / W)
    assert seen["sigma"] == pytest.approx(sigma, rel=1e-6) and seen["h"] == pytest.approx(0.8 * sigma, rel=1e-6)
    assert (seen["patch_size"], seen["patch_distance"], seen["fast_mode"]) == (5, 6, True)


@pytest.mark.parametrize("method,sigma", [("bm3d", "blind"), ("nlm", "blind"), ("nlm", "spike"),
                                          ("bm3d", "spike")])
def test_flat_plane_with_zero_sigma_comes_back_unchanged(method, sigma):
    _needs(method, sigma)
    value = 0.0 if sigma == "spike" else 0.3     # spike σ is 0 only where p̂(1 − p̂) = 0
    planes = np.full((4, 16, 20), value, np.float32)
    out = PeerDenoiser(method, sigma=sigma)(planes, window=W)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, planes)


def test_blind_sigma_nan_counts_as_zero(monkeypatch):
    # estimate_sigma gives NaN when its finest diagonal wavelet band is all zero
    skimage_restoration = pytest.importorskip("skimage.restoration")
    pytest.importorskip("pywt")   # asked for before estimate_sigma is called
    monkeypatch.setattr(skimage_restoration, "estimate_sigma", lambda *a, **k: float("nan"))
    plane = _rates(_truth(shape=(16, 20)))
    assert PeerDenoiser("nlm").plane_sigma(plane) == 0.0
    np.testing.assert_array_equal(PeerDenoiser("nlm")(plane), plane)


def test_gaussian_keeps_a_flat_plane():
    planes = np.full((4, 16, 20), 0.3, np.float32)
    np.testing.assert_allclose(PeerDenoiser("gaussian")(planes), planes, atol=1e-7)


def test_names_for_tables():
    assert PeerDenoiser("bm3d").name == "BM3D (blind σ)"
    assert PeerDenoiser("nlm", sigma="spike").name == "NLM (spike σ)"
    assert PeerDenoiser("nlm", sigma=0.05).name == "NLM (σ=0.05)"
    assert PeerDenoiser("gaussian").name == "Gaussian σ=1.0"
    assert PeerDenoiser("gaussian", gaussian_sigma=2).name == "Gaussian σ=2.0"


@pytest.mark.parametrize("kwargs,exc,word", [
    ({"method": "bm4d"}, ValueError, "method"),
    ({"method": None}, ValueError, "method"),
    ({"method": "nlm", "sigma": "auto"}, ValueError, "sigma"),
    ({"method": "nlm", "sigma": -0.1}, ValueError, "sigma"),
    ({"method": "nlm", "sigma": 0.0}, ValueError, "sigma"),
    ({"method": "nlm", "sigma": float("nan")}, ValueError, "sigma"),
    ({"method": "nlm", "sigma": True}, TypeError, "sigma"),
    ({"method": "nlm", "sigma": [0.1]}, TypeError, "sigma"),
    ({"method": "gaussian", "gaussian_sigma": 0}, ValueError, "gaussian_sigma"),
    ({"method": "gaussian", "gaussian_sigma": "1"}, TypeError, "gaussian_sigma"),
])
def test_bad_constructor_arguments_name_the_argument(kwargs, exc, word):
    with pytest.raises(exc, match=word):
        PeerDenoiser(**kwargs)


def test_bad_call_arguments_name_the_argument():
    den = PeerDenoiser("gaussian")
    with pytest.raises(ValueError, match="planes"):
        den(np.zeros(5, np.float32))
    with pytest.raises(TypeError, match="planes"):
        den(np.zeros((4, 8, 8), np.uint8))
    with pytest.raises(ValueError, match="planes"):
        den(np.full((4, 8, 8), np.nan, np.float32))
    with pytest.raises(ValueError, match="window"):
        den(np.zeros((4, 8, 8), np.float32), window=0)
    with pytest.raises(ValueError, match="window"):
        PeerDenoiser("nlm", sigma="spike")(np.zeros((4, 8, 8), np.float32))
    with pytest.raises(ValueError, match="window"):
        PeerDenoiser("nlm", sigma="spike").plane_sigma(np.zeros((8, 8), np.float32))
    with pytest.raises(ValueError, match="method"):
        peer_available("bm4d")


def test_bm3d_refuses_planes_too_small_for_its_blocks():
    # bm3d 4.0.3 raises under 8 × 8 and crashes the interpreter on exactly 8 × 8; we refuse first.
    with pytest.raises(ValueError, match="9 × 9"):
        PeerDenoiser("bm3d", sigma=0.1)(np.zeros((4, 8, 8), np.float32))


def test_missing_bm3d_says_how_to_install_and_the_licence(monkeypatch):
    monkeypatch.setitem(sys.modules, "bm3d", None)
    assert not peer_available("bm3d") and peer_available("gaussian")
    with pytest.raises(ImportError, match=r'pip install "spikeref\[peers\]"') as info:
        PeerDenoiser("bm3d", sigma=0.1)(np.zeros((4, 16, 16), np.float32))
    message = str(info.value)
    assert "\n" not in message and "non-commercial" in message


def test_missing_skimage_says_how_to_install(monkeypatch):
    for name in [m for m in sys.modules if m == "skimage" or m.startswith("skimage.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "skimage", None)
    assert not peer_available("nlm")
    with pytest.raises(ImportError, match=r'pip install "spikeref\[peers\]"') as info:
        PeerDenoiser("nlm")(np.zeros((4, 16, 16), np.float32))
    assert "\n" not in str(info.value)
    # the gaussian peer needs neither package
    assert PeerDenoiser("gaussian")(np.zeros((4, 16, 16), np.float32)).shape == (4, 16, 16)


def test_missing_pywavelets_says_how_to_install_and_spares_the_spike_sigma(monkeypatch):
    """scikit-image without PyWavelets: the blind σ (estimate_sigma) is refused before any work, in one line;
    NLM with the spike σ does not need it."""
    skimage_restoration = pytest.importorskip("skimage.restoration")
    monkeypatch.setitem(sys.modules, "pywt", None)
    assert not peer_available("nlm")
    with pytest.raises(ImportError, match=r'PyWavelets.*pip install "spikeref\[peers\]"') as info:
        PeerDenoiser("nlm")(_rates(_truth(shape=(16, 16))))
    assert "\n" not in str(info.value)
    monkeypatch.setattr(skimage_restoration, "denoise_nl_means", lambda plane, **kw: plane)
    rates = _rates(_truth(shape=(16, 16)))
    np.testing.assert_array_equal(PeerDenoiser("nlm", sigma="spike")(rates, window=W), rates)


def test_importing_the_package_does_not_import_the_peers_packages():
    import subprocess

    code = ("import sys, spikeref, spikeref.denoise.peers; from spikeref.denoise import PeerDenoiser; "
            "print('bm3d' in sys.modules, 'skimage' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"], out.stderr
