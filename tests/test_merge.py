"""The robust merge and its adaptive support (spikeref.merge): against its oracle, and what it is for."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.merge import MergeParams, default_shells, robust_merge
from spikeref.oracles.merge import robust_merge_oracle


def _scene(h=16, w=18):
    y, x = np.mgrid[0:h, 0:w]
    return 0.3 + 0.15 * np.sin(x / 3.0) * np.cos(y / 4.0)


def _windows(n, sigma, seed, h=16, w=18):
    rng = np.random.default_rng(seed)
    return (_scene(h, w)[None, None] + rng.normal(0.0, sigma, size=(n, 4, h, w))).astype(np.float32)


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 2), st.sampled_from([1, 3, 5]), st.booleans(),
       st.sampled_from([0.0, 3.0, 10.0]))
def test_the_merge_is_its_oracle(seed, half, box, shells, window):
    rng = np.random.default_rng(seed)
    n, h, w = 2 * (half + 2) + 1, 6, 7
    samples = (0.3 + rng.normal(0, 0.05, size=(n, 4, h, w)) + (rng.random((n, 1, 1, 1)) < 0.3) * 0.3)
    weights = rng.integers(0, 4, size=(n, h, w)).astype(np.float64)
    noise = rng.uniform(0.5, 2.0, size=(4, h, w)) * 0.05 ** 2
    ref = n // 2
    core = np.abs(np.arange(n) - ref) <= half
    params = MergeParams(box=box, shells=((half + 1, half + 1), (half + 2, half + 2)) if shells else (),
                         window=window)
    est, windows, final = robust_merge(samples, weights, noise, ref, core, params, final_weights=True)
    want, want_windows, want_final = robust_merge_oracle(samples, weights, noise, ref, core, params,
                                                         final_weights=True)
    np.testing.assert_allclose(est, want, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(windows, want_windows, rtol=1e-5)
    np.testing.assert_allclose(final, want_final, rtol=1e-5, atol=1e-6)
    # the final weights are the estimate's: Σ ω s / Σ ω (before the clip to [0, 1]) and (Σ ω)² / Σ ω²
    merged = np.clip((final[:, None] * samples).sum(axis=0) / final.sum(axis=0)[None], 0.0, 1.0)
    np.testing.assert_allclose(est, merged, rtol=1e-4, atol=1e-5)
    some = final.sum(axis=0) > 1e-6  # (a reference of base weight 0 counts as 1e-12)
    np.testing.assert_allclose(windows[some], (final.sum(axis=0) ** 2 / (final ** 2).sum(axis=0))[some], rtol=1e-4)


def test_where_all_windows_agree_the_core_is_eq_14_15():
    """Noise alone: every window keeps its weight, the merge is the weighted mean (Eq. 14–15's binomial one)."""
    samples = _windows(7, 0.02, 1)
    weights = np.broadcast_to(np.array([1.0, 3, 6, 7, 6, 3, 1])[:, None, None], (7, 16, 18))
    noise = np.full((4, 16, 18), 0.02 ** 2)
    est, windows = robust_merge(samples, weights, noise, 3, np.ones(7, bool))
    plain = (weights[:, None] * samples).sum(0) / weights.sum(0)
    assert np.median(windows) == pytest.approx(27 ** 2 / 141, rel=1e-6)
    assert np.mean(np.abs(windows - 27 ** 2 / 141) < 1e-4) > 0.85  # noise alone passes z0 in a few boxes
    assert np.mean(np.abs(est - plain)) < 5e-4


def test_an_occluder_in_some_windows_is_dropped():
    """A block that two windows show and the reference does not (an occlusion, a ghost) leaves the merge."""
    samples = _windows(7, 0.02, 2)
    samples[[1, 5], :, 4:10, 5:12] += 0.4
    weights = np.ones((7, 16, 18))
    noise = np.full((4, 16, 18), 0.02 ** 2)
    est, windows = robust_merge(samples, weights, noise, 3, np.ones(7, bool))
    plain = samples.mean(0)
    truth = _scene()[None]
    assert np.abs(est - truth)[:, 5:9, 6:11].max() < 0.06 < np.abs(plain - truth)[:, 5:9, 6:11].min()
    assert windows[6, 8] < 5.5 and np.median(windows[12:, :]) == pytest.approx(7.0)


def test_the_support_grows_where_the_scene_holds_still_and_not_where_it_moves():
    """Twenty-one windows of a static scene, but on the left the far windows show something else (an object that
    moved in after the core's time): shells are taken on the right, refused on the left."""
    n = 21
    samples = _windows(n, 0.05, 3, 16, 24)
    far = np.abs(np.arange(n) - 10) > 3
    samples[far, :, :, :10] += 0.08  # under 2σ of one window: each far window alone passes the test
    weights = np.ones((n, 16, 24))
    noise = np.full((4, 16, 24), 0.05 ** 2)
    core = ~far
    params = MergeParams(shells=default_shells(3, 10))
    est, windows = robust_merge(samples, weights, noise, 10, core, params)
    robust, robust_windows = robust_merge(samples, weights, noise, 10, core, MergeParams())
    assert np.mean(windows[:, 16:]) > 12 and np.mean(windows[:, :6]) < 8
    truth = _scene(16, 24)[None]
    err = lambda e: float(np.mean((e - truth)[:, :, 14:] ** 2))  # noqa: E731
    assert err(est) < 0.75 * err(robust)  # static: more windows, less noise (21 against 7 at most)


def test_the_window_keeps_the_floor_up_to_one_spike_a_window_and_lowers_it_above():
    """MergeParams.window = W: the shells' noise floor φ v in full where the merge gives at most one spike a
    window (a window W so short that e W ≤ 1 everywhere is the plain floor), φ v / (e W) above (so a very long
    window is no floor at all, as φ = 0)."""
    rng = np.random.default_rng(3)
    samples = _windows(21, 0.03, 5)
    samples[:3, :, 4:12, 4:12] += 0.05  # far windows a little off: the shells' test has something to weigh
    weights = np.ones((21, 16, 18))
    noise = np.full((4, 16, 18), 0.03 ** 2) * rng.uniform(1.0, 2.0, (4, 16, 18))  # the model above the scatter
    core = np.abs(np.arange(21) - 10) <= 3
    shells = default_shells(3, 10)

    def merge(**kw):
        return robust_merge(samples, weights, noise, 10, core, MergeParams(shells=shells, **kw))

    plain, short, none_, long_ = merge(), merge(window=0.5), merge(noise_floor=0.0), merge(window=1e9)
    for a, b in ((plain, short), (none_, long_)):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(plain[1], none_[1])  # the floor matters on this input
    with pytest.raises(ValueError, match="window"):
        MergeParams(window=-1.0)


def test_default_shells_and_parameters():
    assert default_shells(3, 20) == ((4, 6), (7, 10), (11, 16), (17, 20))
    assert default_shells(3, 3) == ()
    assert MergeParams(shells=[[4, 6]]).shells == ((4, 6),) and MergeParams(shells=((4, 6),)).reach == 6
    for bad, match in (({"box": 4}, "box must be an odd"), ({"z": 0}, "z must be a finite"),
                       ({"iterations": 0}, "iterations must be"), ({"shells": ((4, 6), (5, 8))}, "shells must be")):
        with pytest.raises(ValueError, match=match):
            MergeParams(**bad)


def test_bad_arguments_are_named():
    s = np.zeros((3, 4, 5, 5), np.float32)
    w = np.ones((3, 5, 5))
    v = np.full((4, 5, 5), 1e-3)
    core = np.ones(3, bool)
    with pytest.raises(ValueError, match="samples must have shape"):
        robust_merge(s[0], w, v, 1, core)
    with pytest.raises(ValueError, match="weights must be finite"):
        robust_merge(s, -w, v, 1, core)
    with pytest.raises(ValueError, match="noise must be"):
        robust_merge(s, w, v[:2], 1, core)
    with pytest.raises(ValueError, match="reference must index"):
        robust_merge(s, w, v, 3, core)
    with pytest.raises(ValueError, match="core must be"):
        robust_merge(s, w, v, 1, np.array([True, False, True]))
    with pytest.raises(TypeError, match="params must be a MergeParams"):
        robust_merge(s, w, v, 1, core, {"box": 3})
    bad = s.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="samples must be finite"):
        robust_merge(bad, w, v, 1, core)


def test_the_compiled_merge_runs_no_python_code_per_call(monkeypatch):
    """A parallel kernel that makes or returns an array unpickles objects (Python code) at every call; a Ctrl-C
    pending from the compiled part then surfaces there as a SystemError, not a KeyboardInterrupt (seen in
    tests/test_faults.py's signal test).  The merge's kernel takes every buffer from its caller."""
    numba_serialize = pytest.importorskip("numba.core.serialize")
    samples = _windows(9, 0.02, 3, h=12, w=14)
    args = (samples, np.ones((9, 12, 14)), np.full((4, 12, 14), 0.02 ** 2), 4,
            np.abs(np.arange(9) - 4) <= 1, MergeParams(shells=((2, 4),)))
    robust_merge(*args)  # compiled (or loaded from the cache) here
    calls = []
    real = numba_serialize._numba_unpickle
    monkeypatch.setattr(numba_serialize, "_numba_unpickle", lambda *a: calls.append(a) or real(*a))
    robust_merge(*args)
    assert calls == []


def test_unchecked_call_gives_the_same_merge():
    """``check=False`` (the pipeline's call) skips the value checks, not the merge."""
    samples = _windows(9, 0.02, 4, h=12, w=14)
    args = (samples, np.ones((9, 12, 14), np.float32), np.full((4, 12, 14), 0.02 ** 2), 4,
            np.abs(np.arange(9) - 4) <= 1, MergeParams(shells=((2, 4),)))
    for got, want in zip(robust_merge(*args, check=False), robust_merge(*args), strict=True):
        np.testing.assert_array_equal(got, want)
