"""The CFA phase read from the spikes (spikeref.cfa_detect) and its literal oracle."""

from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from spikeref.cfa_detect import (
    DETECTED_PATTERNS,
    CfaDetectParams,
    CfaGuess,
    cfa_from_counts,
    detect_cfa,
    green_diagonal,
    green_sites_contradict,
)
from spikeref.io.dat import write_dat
from spikeref.oracles.cfa_detect import DEFAULTS, cfa_from_counts_oracle
from spikeref.simulate import load_scene, simulate
from spikeref.stream import read_dat

SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"
PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
POSITIONS = ((0, 0), (0, 1), (1, 0), (1, 1))


@pytest.fixture(scope="module")
def chart():
    """The colour chart (red brighter than blue, realistic noise), 48×64, 200 planes, in each phase and mono."""
    def make(cfa):
        scene = load_scene(SCENES / "color_chart.toml",
                           overrides={"planes": 200, "camera": {"cfa": cfa}, "content": {"height": 48, "width": 64}})
        return simulate(scene, seed=1).spikes
    return {cfa: make(cfa) for cfa in (*PATTERNS, "mono")}


def shifted(pattern: str, dy: int, dx: int) -> str:
    """The pattern of a mosaic whose pixel (y, x) is the old one's (y + dy, x + dx)."""
    return "".join(pattern[2 * ((py + dy) % 2) + (px + dx) % 2] for py, px in POSITIONS)


def colour_counts(seed: int, pattern: str | None, *, h=64, w=80, planes=200, red_over_blue=1.5, rate=0.2):
    """Spike counts of a periodic random colour scene (shared luminance texture, red and blue each with a
    texture of their own) behind ``pattern`` (None: a mono sensor sees the luminance), Poisson noise."""
    rng = np.random.default_rng(seed)

    def texture():
        t = ndimage.gaussian_filter(rng.standard_normal((h, w)), 2.0, mode="wrap")  # periodic: rolls stay whole
        return t / t.std()

    lum, own_r, own_b = texture(), texture(), texture()
    rgb = {"R": red_over_blue * (1 + 0.3 * (lum + 0.8 * own_r)), "G": 1 + 0.3 * lum,
           "B": 1 + 0.3 * (lum + 0.8 * own_b)}
    rates = np.empty((h, w))
    for pos, (py, px) in enumerate(POSITIONS):
        channel = rgb[pattern[pos]] if pattern else 1 + 0.3 * lum
        rates[py::2, px::2] = channel[py::2, px::2]
    rates = np.clip(rate * rates / 1.5, 0, 1)
    return rng.poisson(rates * planes).astype(np.int64)


# ----------------------------------------------------------------------------- what it finds
@pytest.mark.parametrize("cfa", PATTERNS)
def test_the_four_phases_of_a_simulated_colour_scene_are_found(chart, cfa):
    guess = detect_cfa(chart[cfa])
    assert guess.pattern == cfa
    assert guess.green_confidence >= CfaDetectParams().warn_confidence
    assert 0.5 < guess.confidence <= CfaDetectParams().red_prior  # the red/blue prior caps it
    green = guess.corr_main if guess.green_diagonal == "main" else guess.corr_anti
    other = guess.corr_anti if guess.green_diagonal == "main" else guess.corr_main
    assert green > 0.8 and other < 0.3 and guess.planes == 200
    means = dict(zip(cfa, guess.phase_means, strict=True))
    assert means["R"] > means["B"]


def test_a_mono_recording_reads_mono(chart):
    guess = detect_cfa(chart["mono"])
    assert guess.pattern == "mono" and guess.green_diagonal is None and guess.green_confidence == 0.0
    assert guess.confidence > 0.9 and abs(guess.corr_main - guess.corr_anti) < 0.05
    assert max(guess.phase_means) / min(guess.phase_means) < 1.02
    assert not green_sites_contradict("RGGB", guess) and not green_sites_contradict(None, guess)


def test_no_spikes_and_very_few_spikes_read_mono_without_confidence():
    zero = detect_cfa(np.zeros((20, 16, 20), np.uint8))
    assert zero.pattern == "mono" and zero.confidence == 0.0 and zero.phase_means == (0.0, 0.0, 0.0, 0.0)
    # a colour scene seen through 1 % of its spikes: the texture is noise, the answer says it cannot tell
    dark = cfa_from_counts(colour_counts(3, "GBRG", planes=2, rate=0.05), 2)
    assert dark.confidence < 0.5 and (dark.pattern == "mono" or dark.green_confidence < 0.99)
    bright = cfa_from_counts(colour_counts(3, "GBRG"), 200)
    assert bright.pattern == "GBRG" and bright.green_confidence > 0.99


def test_grey_texture_under_coloured_light_is_decided_by_the_means():
    # no colour texture at all (red and blue follow the luminance): the two green phases still agree in mean
    rng = np.random.default_rng(5)
    lum = 1 + 0.3 * ndimage.gaussian_filter(rng.standard_normal((64, 80)), 2.0)
    gains = {"R": 1.3, "G": 1.0, "B": 0.7}
    rates = np.empty((64, 80))
    for pos, (py, px) in enumerate(POSITIONS):
        rates[py::2, px::2] = 0.1 * gains["BGGR"[pos]] * lum[py::2, px::2]
    guess = cfa_from_counts(rng.poisson(rates * 400), 400)
    assert abs(guess.texture_z) < 3 < abs(guess.means_z)
    assert guess.pattern == "BGGR" and guess.green_confidence > 0.99


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), pattern=st.sampled_from(PATTERNS), dy=st.integers(0, 1), dx=st.integers(0, 1))
def test_rolling_the_mosaic_permutes_the_detected_pattern(seed, pattern, dy, dx):
    """A mosaic read one row (column) further on is another phase of the same sensor: RGGB → GBRG for a row,
    RGGB → GRBG for a column, RGGB → BGGR for both; the detector follows."""
    counts = colour_counts(seed, pattern)
    assert cfa_from_counts(counts, 200).pattern == pattern
    rolled = np.roll(counts, (-dy, -dx), axis=(0, 1))  # new pixel (y, x) is the old (y + dy, x + dx)
    assert cfa_from_counts(rolled, 200).pattern == shifted(pattern, dy, dx)
    assert shifted("RGGB", 1, 0) == "GBRG" and shifted("RGGB", 0, 1) == "GRBG" and shifted("RGGB", 1, 1) == "BGGR"


@settings(max_examples=40, deadline=None)
@given(counts=st.integers(0, 6).flatmap(lambda n: st.lists(st.integers(0, 50), min_size=48, max_size=48)),
       planes=st.integers(50, 60), shape=st.sampled_from([(6, 8), (8, 6), (4, 12), (2, 24)]))
def test_the_confidence_is_in_the_unit_interval_and_the_answer_one_of_five(counts, planes, shape):
    guess = cfa_from_counts(np.array(counts).reshape(shape), planes)
    assert guess.pattern in DETECTED_PATTERNS
    assert 0.0 <= guess.confidence <= 1.0 and 0.0 <= guess.green_confidence <= 1.0
    assert all(np.isfinite([guess.corr_main, guess.corr_anti, guess.texture_z, guess.means_z, guess.colour_z]))
    assert -1 <= guess.corr_main <= 1 and -1 <= guess.corr_anti <= 1
    if guess.pattern != "mono":
        assert guess.confidence <= guess.green_confidence


def test_red_is_the_brighter_of_the_two_non_green_phases():
    # the same scene with red and blue brightness swapped reads as the pattern with red and blue swapped:
    # the prior, not the data, names them (a blue-dominated scene reads wrong, by design)
    warm = cfa_from_counts(colour_counts(7, "RGGB", red_over_blue=1.5), 200)
    cold = cfa_from_counts(colour_counts(7, "RGGB", red_over_blue=1 / 1.5), 200)
    assert warm.pattern == "RGGB" and cold.pattern == "BGGR"
    assert cold.green_confidence > 0.99  # the green sites are still right


# ----------------------------------------------------------------------------- reading the stream
def test_it_reads_a_bounded_number_of_planes_once(monkeypatch):
    import spikeref.cfa_detect as cd

    calls = []
    real = cd.window_counts

    def spy(stream, window, start=0, count=None, out=None):
        calls.append((window, start, count))
        return real(stream, window, start=start, count=count, out=out)

    monkeypatch.setattr(cd, "window_counts", spy)
    spikes = np.zeros((1500, 8, 8), np.uint8)
    assert detect_cfa(spikes).planes == 1000 and calls == [(1000, 0, 1)]
    assert detect_cfa(spikes, planes=300, start=1400).planes == 100  # the stream ends first
    # 8 bytes a packed plane of 8×8: 40 bytes allow 5 planes
    assert detect_cfa(spikes, params=CfaDetectParams(max_bytes=40)).planes == 5
    assert detect_cfa(spikes, start=7, planes=2).planes == 2 and calls[-1] == (2, 7, 1)


def test_a_packed_dat_and_the_array_give_the_same_answer(chart, tmp_path):
    spikes = chart["GRBG"]
    write_dat(tmp_path / "r.dat", spikes)
    packed = detect_cfa(read_dat(tmp_path / "r.dat", 48, 64))
    assert packed == detect_cfa(spikes)
    assert packed.pattern == "GRBG"


def test_green_sites_and_contradiction():
    assert green_diagonal("RGGB") == green_diagonal("bggr") == "anti"
    assert green_diagonal("GRBG") == green_diagonal("GBRG") == "main"
    assert green_diagonal(None) is None and green_diagonal("mono") is None
    strong = cfa_from_counts(colour_counts(1, "GBRG"), 200)
    assert strong.pattern == "GBRG" and strong.green_confidence > 0.99
    assert green_sites_contradict("RGGB", strong) and green_sites_contradict("BGGR", strong)
    assert green_sites_contradict(None, strong) and green_sites_contradict("mono", strong)  # colour read as mono
    assert not green_sites_contradict("GBRG", strong) and not green_sites_contradict("GRBG", strong)
    assert not green_sites_contradict("RGGB", strong, threshold=1.0 - 1e-300) or strong.green_confidence == 1.0
    weak = CfaGuess("GBRG", 0.4, 0.5, 0.5, 0.4, (0.1,) * 4, 10, 1.0, 0.0, 3.5)
    assert not green_sites_contradict("RGGB", weak)  # not sure enough to contradict anyone


def test_the_guess_is_auditable():
    guess = cfa_from_counts(colour_counts(2, "RGGB"), 200)
    d = guess.as_dict()
    assert set(d) == {f.name for f in fields(CfaGuess)} and isinstance(d["phase_means"], list)
    assert "green at (0,1)/(1,0)" in guess.describe() and "warm-world prior" in guess.describe()
    mono = cfa_from_counts(colour_counts(2, None), 200)
    assert mono.pattern == "mono" and "behave alike" in mono.describe()


# ----------------------------------------------------------------------------- bad arguments
@pytest.mark.parametrize("call, exc, name", [
    (lambda: cfa_from_counts(np.zeros((3, 4)), 10), ValueError, "counts"),
    (lambda: cfa_from_counts(np.zeros((4, 4, 1)), 10), ValueError, "counts"),
    (lambda: cfa_from_counts(np.zeros((4, 4), bool), 10), TypeError, "counts"),
    (lambda: cfa_from_counts(-np.ones((4, 4)), 10), ValueError, "counts"),
    (lambda: cfa_from_counts(np.full((4, 4), np.nan), 10), ValueError, "counts"),
    (lambda: cfa_from_counts(np.zeros((4, 4)), 0), ValueError, "planes"),
    (lambda: cfa_from_counts(np.zeros((4, 4)), 2.5), ValueError, "planes"),
    (lambda: cfa_from_counts(np.zeros((4, 4)), 5, params={"tiles": 2}), TypeError, "params"),
    (lambda: detect_cfa(np.zeros((5, 4, 4), np.uint8), planes=0), ValueError, "planes"),
    (lambda: detect_cfa(np.zeros((5, 4, 4), np.uint8), start=-1), ValueError, "start"),
    (lambda: detect_cfa(np.zeros((5, 4, 4), np.uint8), start=5), ValueError, "start"),
    (lambda: detect_cfa(np.zeros((5, 3, 4), np.uint8)), ValueError, "even height and width"),
    (lambda: detect_cfa(np.full((5, 4, 4), 2, np.uint8)), ValueError, "spikes"),
    (lambda: CfaDetectParams(planes=0), ValueError, "planes"),
    (lambda: CfaDetectParams(tiles=1), ValueError, "tiles"),
    (lambda: CfaDetectParams(band=(4.0, 1.0)), ValueError, "band"),
    (lambda: CfaDetectParams(red_prior=0.3), ValueError, "red_prior"),
    (lambda: CfaDetectParams(decide_z=float("nan")), ValueError, "decide_z"),
    (lambda: CfaDetectParams(warn_confidence=0), ValueError, "warn_confidence"),
    (lambda: green_diagonal("RGBG"), ValueError, "cfa"),
    (lambda: green_sites_contradict("RGGB", "GBRG"), TypeError, "guess"),
    (lambda: green_sites_contradict("RGGB", cfa_from_counts(np.zeros((4, 4)), 1), threshold=2), ValueError,
     "threshold"),
])
def test_bad_arguments_name_the_argument(call, exc, name):
    with pytest.raises(exc, match=name):
        call()


# ----------------------------------------------------------------------------- the oracle
def test_the_oracle_writes_out_the_same_defaults():
    params = CfaDetectParams()
    assert DEFAULTS == {k: getattr(params, k) for k in DEFAULTS}


@pytest.mark.parametrize("case", ["colour", "mono", "grey texture", "dark", "tiny", "zeros", "one row"])
def test_the_fast_decision_is_the_oracle(case):
    rng = np.random.default_rng(11)
    counts, planes = {
        "colour": (colour_counts(4, "GRBG", h=24, w=32), 200),
        "mono": (colour_counts(4, None, h=24, w=32), 200),
        "grey texture": (rng.poisson(np.tile([[30.0, 20.0], [20.0, 12.0]], (10, 14))
                                     * (1 + 0.2 * rng.standard_normal((20, 28)))), 100),
        "dark": (rng.poisson(0.3, (16, 22)), 30),
        "tiny": (rng.poisson(5.0, (6, 6)), 10),
        "zeros": (np.zeros((10, 12)), 5),
        "one row": (rng.poisson(5.0, (2, 12)), 10),
    }[case]
    fast = cfa_from_counts(counts, planes).as_dict()
    slow = cfa_from_counts_oracle(counts, planes)
    assert fast["pattern"] == slow["pattern"]
    for key in ("confidence", "green_confidence", "corr_main", "corr_anti", "texture_z", "means_z", "colour_z"):
        assert fast[key] == pytest.approx(slow[key], rel=1e-9, abs=1e-9), key
    np.testing.assert_allclose(fast["phase_means"], slow["phase_means"], rtol=1e-12)


# ----------------------------------------------------------------------------- real recordings
def test_the_real_monochrome_recordings_read_mono(real_data):
    from spikeref.stream import load_spikes

    sim = detect_cfa(load_spikes(real_data / "spikingsim_real_spike.npz", axes="HWT"))
    zoo = detect_cfa(load_spikes(real_data / "spikezoo_uhsr.npz"))
    reds = detect_cfa(read_dat(real_data / "spikezoo_data_reds_sim_250x400.dat", 250, 400))
    for guess in (sim, zoo, reds):
        assert guess.pattern == "mono" and guess.confidence > 0.9, guess
    assert sim.planes == 500 and zoo.planes == 200 and reds.planes == 301
