"""The composed warp (spikeref.compose): the oracle, what it reduces to, and that one resample keeps detail."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.compose import RESAMPLES, catmull_rom_weights, composed_warp, path_table
from spikeref.oracles.compose import composed_warp_oracle
from spikeref.warp import warp_average


def test_catmull_rom_weights():
    assert catmull_rom_weights(0.0) == (0.0, 1.0, 0.0, 0.0)  # it passes through the samples
    w = catmull_rom_weights(0.5)
    assert w == pytest.approx((-0.0625, 0.5625, 0.5625, -0.0625)) and sum(w) == pytest.approx(1.0)


def test_path_table():
    paths = path_table(3, 2)
    assert len(paths) == 9 and paths[0] == (-1, -1) and paths[4] == (0, 0)
    assert len(path_table(5, 3)) == 125 and path_table(1, 3) == [(0, 0, 0)]


@settings(max_examples=12, deadline=None)
@given(st.integers(2, 7), st.integers(2, 7), st.integers(1, 3), st.integers(0, 10_000), st.sampled_from(RESAMPLES))
def test_matches_the_oracle(h, w, nhop, seed, resample):
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 11, (3, 2, h, w)).astype(np.float32)
    bank = rng.uniform(-1.5, 1.5, (4, 2, h, w)).astype(np.float32)
    hops = rng.integers(-1, 4, (5, nhop))
    targets = rng.integers(0, 3, 5)
    got = composed_warp(counts, bank, hops, targets, 10, resample)
    want = composed_warp_oracle(counts, bank, hops, targets, 10, resample)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


def test_one_sample_per_window():
    """``resample="window"``: paths into one window at the same position give the per-path frame; at different
    positions the window is sampled once at their mean (a cubic through a ramp is exact: the same value),
    weighted by the number of paths, and a path outside the plane is left out of the mean and the weight."""
    rng = np.random.default_rng(4)
    counts = rng.integers(0, 11, (2, 1, 8, 9)).astype(np.float32)
    bank = np.zeros((2, 2, 8, 9), np.float32)
    bank[0, 1] = 0.5  # half a pixel right
    bank[1, 1] = -0.5
    hops = np.array([[0, 1], [1, 0], [-1, -1]])  # two routes to window 0 that end where they began; one to 1
    targets = np.array([0, 0, 1])
    np.testing.assert_array_equal(composed_warp(counts, bank, hops, targets, 1, "window"),
                                  composed_warp(counts, bank, hops, targets, 1, "path"))
    # Catmull–Rom reproduces a parabola exactly, so a sample is q(position): one sample at the mean
    # position gives q(x + 0.375), two samples averaged (one per path) give a different value
    q = lambda x: (x / 9.0) ** 2  # noqa: E731
    parabola = np.broadcast_to(q(np.arange(9)).astype(np.float32), (2, 1, 8, 9)).copy()
    bank[1, 1] = 0.25
    apart = np.array([[0, -1], [1, -1]])  # window 0 at x + 0.5 and x + 0.25
    x = np.arange(1, 7)
    got = composed_warp(parabola, bank, apart, np.array([0, 0]), 1, "window")
    np.testing.assert_allclose(got[0, :, 1:7], q(x + 0.375)[None] * np.ones((8, 1)), rtol=1e-5)
    per_path = composed_warp(parabola, bank, apart, np.array([0, 0]), 1, "path")
    np.testing.assert_allclose(per_path[0, :, 1:7], ((q(x + 0.5) + q(x + 0.25)) / 2)[None] * np.ones((8, 1)),
                               rtol=1e-5)
    assert np.abs(got - per_path)[0, :, 1:7].min() > 1e-4  # the two modes differ everywhere here
    bank[0, 1] = 30.0  # the first path leaves the plane: the mean is the second path's alone
    got = composed_warp(parabola, bank, apart, np.array([0, 0]), 1, "window")
    np.testing.assert_allclose(got[0, :, 1:7], q(x + 0.25)[None] * np.ones((8, 1)), rtol=1e-5)
    with pytest.raises(ValueError, match="resample must be one of path, window; got 'pixel'"):
        composed_warp(counts, bank, hops, targets, 1, "pixel")


def test_paths_share_the_positions_of_their_common_first_hops():
    # The kernel moves each distinct sequence of first hops once: K + K² + … + K^L nodes for the K^L paths
    # of Eq. 14–15 when every prefix has its own flow; paths in any order give the same frame.
    from spikeref.compose import _hop_tree

    rng = np.random.default_rng(2)
    paths = path_table(3, 3)
    table, hops = {}, np.empty((27, 3), int)
    for p, path in enumerate(paths):
        for m in range(3):
            table.setdefault(path[: m + 1], -1 if path[m] == 0 else len(table) % 6)  # one flow per prefix
            hops[p, m] = table[path[: m + 1]]
    flow, parent, start, leaf = _hop_tree(hops)
    assert list(start) == [0, 3, 12, 39] and len(set(leaf)) == 27
    assert all(parent[q] == -1 for q in range(3)) and all(0 <= parent[q] < 3 for q in range(3, 12))
    counts = rng.integers(0, 11, (7, 2, 9, 11)).astype(np.float32)
    bank = rng.uniform(-1.5, 1.5, (6, 2, 9, 11)).astype(np.float32)
    targets = np.array([3 + sum(path) for path in paths])
    got = composed_warp(counts, bank, hops, targets, 10)
    np.testing.assert_allclose(got, composed_warp_oracle(counts, bank, hops, targets, 10), rtol=1e-5, atol=1e-6)
    order = rng.permutation(27)
    np.testing.assert_allclose(composed_warp(counts, bank, hops[order], targets[order], 10), got, rtol=1e-6, atol=1e-7)


def test_integer_flows_reduce_to_shifted_windows():
    """With whole-pixel flows the cubic hits samples exactly: the average of the shifted windows."""
    rng = np.random.default_rng(2)
    counts = rng.integers(0, 11, (2, 1, 12, 14)).astype(np.float32)
    bank = np.zeros((1, 2, 12, 14), np.float32)
    bank[0, 1] = 1.0  # one pixel to the right
    out = composed_warp(counts, bank, np.array([[-1], [0]]), np.array([0, 1]), 10)
    expect = (counts[0, 0, :, :-1] + counts[1, 0, :, 1:]) / 20
    np.testing.assert_allclose(out[0, :, :-1], expect, rtol=1e-6)
    # the last column's second sample falls outside: renormalised to the reference alone
    np.testing.assert_allclose(out[0, :, -1], counts[0, 0, :, -1] / 10, rtol=1e-6)


def test_constant_flows_compose_like_the_chain_and_keep_more_detail():
    """Constant half-pixel flows: the chained bilinear warps blur a fine pattern; one cubic resample keeps it."""
    h, w = 16, 40
    x = np.arange(w)
    pattern = (0.5 + 0.4 * np.cos(2 * np.pi * x / 3.0))[None, None, :] * np.ones((1, 1, h, w))
    shift = 0.5
    # window j shows the pattern moved by j·shift px; flows from a frame to its neighbour are ±shift
    wins = np.stack([np.interp(x - j * shift, x, pattern[0, 0, 0], period=w)[None, None, :] * np.ones((1, h, w))
                     for j in range(-2, 3)]).astype(np.float32)[:, :, :, :]
    bank = np.zeros((2, 2, h, w), np.float32)
    bank[0, 1], bank[1, 1] = -shift, shift  # backward flow to the window on the left / right
    paths = path_table(3, 2)
    hops = np.array([[-1 if i == 0 else (0 if i < 0 else 1) for i in p] for p in paths])
    targets = np.array([2 + sum(p) for p in paths])
    composed = composed_warp(wins, bank, hops, targets, 1.0)
    # the chain: step 1 warps windows k-1, k, k+1 for frames -1, 0, 1; step 2 warps those again
    flows = np.stack([np.stack([np.zeros((h, w)), np.full((h, w), i * shift)]) for i in (-1, 0, 1)])
    step1 = [warp_average(wins[c - 1:c + 2], flows) for c in (1, 2, 3)]
    chain = warp_average(np.stack(step1), flows)[0]
    inner = (slice(None), slice(4, -4))
    truth = pattern[0, 0][inner]
    assert np.abs(composed[0][inner] - truth).mean() < 0.5 * np.abs(chain[inner] - truth).mean()


def test_bad_arguments():
    c = np.zeros((2, 1, 4, 4), np.float32)
    b = np.zeros((1, 2, 4, 4), np.float32)
    with pytest.raises(ValueError, match="counts must have shape"):
        composed_warp(c[0], b, np.zeros((1, 1), int), np.zeros(1, int), 1)
    with pytest.raises(ValueError, match="bank must have shape"):
        composed_warp(c, b[:, :1], np.zeros((1, 1), int), np.zeros(1, int), 1)
    with pytest.raises(ValueError, match="hops must index the bank"):
        composed_warp(c, b, np.full((1, 1), 3), np.zeros(1, int), 1)
    with pytest.raises(ValueError, match="targets must index the counts"):
        composed_warp(c, b, np.zeros((1, 1), int), np.full(1, 2), 1)
    with pytest.raises(ValueError, match="window must be a positive"):
        composed_warp(c, b, np.zeros((1, 1), int), np.zeros(1, int), 0)


# ------------------------------------------------------------------------- samples kept apart (spikeref.merge's input)
def test_composed_samples_are_the_composed_warps_windows_kept_apart():
    """Σ kept·samples / Σ kept, clipped, is composed_warp(resample="window"), on the golden case's inputs."""
    from spikeref.compose import composed_samples
    from spikeref.oracles.compose import GOLDEN_CASES

    i = GOLDEN_CASES[0].make_inputs()
    samples, kept, pos = composed_samples(i["counts"], i["bank"], i["hops"], i["targets"], int(i["window"]))
    want = composed_warp(i["counts"], i["bank"], i["hops"], i["targets"], int(i["window"]), "window")
    got = np.clip((kept[:, None] * samples).sum(0) / kept.sum(0)[None], 0, 1)
    np.testing.assert_allclose(got, want, atol=2e-7)
    assert kept.sum(0).max() == len(i["hops"]) and kept.sum(0).min() < len(i["hops"])  # some paths leave
    assert np.array_equal(np.isnan(pos[:, 0]), kept == 0) and np.all(samples.transpose(1, 0, 2, 3)[:, kept == 0] == 0)


def test_composed_samples_take_the_reference_at_its_own_pixels():
    """``identity=k``: the reference window is its own count / W at the grid, whatever its round-trip paths compose
    to (the golden case's random flows: ``+1`` then ``−1`` does not return to the pixel); the other windows and every
    ``kept`` are as without it."""
    from spikeref.compose import composed_samples
    from spikeref.oracles.compose import GOLDEN_CASES

    i = GOLDEN_CASES[0].make_inputs()
    args = (i["counts"], i["bank"], i["hops"], i["targets"], int(i["window"]))
    ref = int(np.median(i["targets"]))  # k: the middle window, 2 of 0 … 4
    plain = composed_samples(*args)
    samples, kept, pos = composed_samples(*args, identity=ref)
    own = i["counts"][ref] / np.float32(i["window"])
    assert np.abs(plain[0][ref] - own).max() > 0.05  # the mean end of its paths is not its own pixel
    np.testing.assert_array_equal(samples[ref], own.astype(np.float32))
    grid = np.stack(np.mgrid[0:own.shape[1], 0:own.shape[2]]).astype(np.float32)
    np.testing.assert_array_equal(pos[ref], grid)
    others = np.arange(len(samples)) != ref
    np.testing.assert_array_equal(samples[others], plain[0][others])
    np.testing.assert_array_equal(pos[others], plain[2][others])
    np.testing.assert_array_equal(kept, plain[1])
    for bad in (-1, len(samples), True, 1.0):
        with pytest.raises(ValueError, match="identity must index the windows"):
            composed_samples(*args, identity=bad)


def test_chained_samples_follow_a_translation_and_stop_at_the_border():
    """Flows of a whole-pixel shift: the chain lands on x + i·shift in window i and is dropped once it leaves."""
    from spikeref.compose import chained_samples

    rng = np.random.default_rng(3)
    m, h, w = 4, 6, 9
    counts = rng.integers(0, 5, size=(m, 2, h, w)).astype(np.float32)
    flows = np.zeros((m, 2, h, w), np.float32)
    flows[:, 1] = 2.0  # two plane pixels to the right per window
    start = np.stack(np.mgrid[0:h, 0:w]).astype(np.float64)
    start[:, 0, 0] = np.nan  # a pixel whose chain does not start
    samples, valid = chained_samples(counts, start, flows, 4)
    for i in range(m):
        shift = 2 * (i + 1)
        inside = np.arange(w) + shift <= w - 1
        assert np.all(valid[i][:, inside][1:] == 1) and np.all(valid[i][:, ~inside] == 0)
        np.testing.assert_allclose(samples[i][:, 1:, inside], counts[i][:, 1:, shift:] / 4, atol=1e-6)
    assert np.all(valid[:, 0, 0] == 0)
    _, _, pos = chained_samples(counts, start, flows, 4, positions=True)
    for i in range(m):  # where the chain is: (y, x + 2(i + 1)) while inside, NaN after
        inside = valid[i] > 0
        np.testing.assert_allclose(pos[i, 1][inside], (start[1] + 2 * (i + 1))[inside])
        np.testing.assert_allclose(pos[i, 0][inside], start[0][inside])
        assert np.all(np.isnan(pos[i][:, ~inside]))
    with pytest.raises(ValueError, match="one flow per window"):
        chained_samples(counts, start, flows[:2], 4)
    with pytest.raises(ValueError, match="start must have shape"):
        chained_samples(counts, start[:, :2], flows, 4)
