"""The NumPy U-Net (spikeref.denoise.unet): convolution, padding, weights files, parity with PyTorch."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.denoise._conv_alternatives import conv3x3_im2col, conv3x3_plain
from spikeref.denoise.conv import conv3x3
from spikeref.denoise.unet import UNet, UNetSpec, exposure_level, layer_shapes
from spikeref.oracles.unet import conv3x3_oracle, unet_forward_oracle

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "unet_forward.npz"


def _conv_im2col(x, w, b, slope):
    """conv3x3_im2col on channel-first arrays (the layout of conv3x3_plain)."""
    cin, cout = w.shape[1], w.shape[0]
    wmat = np.ascontiguousarray(w.transpose(2, 3, 1, 0).reshape(9 * cin, cout))
    return conv3x3_im2col(np.ascontiguousarray(x.transpose(0, 2, 3, 1)), wmat, b, slope).transpose(0, 3, 1, 2)


def test_the_paper_counts_25_convolutions():
    shapes = layer_shapes(UNetSpec(width=32))
    assert len(shapes) == 25  # supplement §8
    assert shapes["head0"] == (1, 32) and shapes["tail2"] == (16, 1) and shapes["dec3a"] == (64, 32)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 2), cin=st.integers(1, 5), cout=st.integers(1, 9), h=st.integers(1, 9),
       w=st.integers(1, 9), slope=st.sampled_from([None, 0.0, 0.1]), seed=st.integers(0, 2**16))
def test_conv_direct_im2col_and_plain_equal_the_oracle(n, cin, cout, h, w, slope, seed):
    # cout up to 9 and h up to 9: the direct kernel works on two output channels of two rows, the last ones alone.
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, cin, h, w)).astype(np.float32)
    wt = rng.standard_normal((cout, cin, 3, 3)).astype(np.float32)
    b = rng.standard_normal(cout).astype(np.float32)
    expected = conv3x3_oracle(x, wt, b, slope)
    np.testing.assert_allclose(conv3x3(x, wt, b, slope), expected, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(conv3x3_plain(x, wt, b, slope), expected, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(_conv_im2col(x, wt, b, slope), expected, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("conv", [conv3x3, _conv_im2col, conv3x3_oracle], ids=["direct", "im2col", "oracle"])
def test_conv_known_values(conv):
    # A centre-tap kernel of 2 and bias 1 doubles and shifts; the corner-tap kernel (dy=dx=0)
    # reads the pixel up-left of each output (zero outside): cross-correlation, as PyTorch.
    x = np.arange(12, dtype=np.float32).reshape(1, 1, 3, 4)
    centre = np.zeros((1, 1, 3, 3), np.float32)
    centre[0, 0, 1, 1] = 2.0
    np.testing.assert_array_equal(conv(x, centre, np.ones(1, np.float32), None), 2 * x + 1)
    corner = np.zeros((1, 1, 3, 3), np.float32)
    corner[0, 0, 0, 0] = 1.0
    expected = np.zeros_like(x)
    expected[..., 1:, 1:] = x[..., :-1, :-1]
    np.testing.assert_array_equal(conv(x, corner, np.zeros(1, np.float32), None), expected)
    neg = -np.ones((1, 1, 3, 4), np.float32)
    np.testing.assert_allclose(conv(neg, centre, np.zeros(1, np.float32), 0.1), -0.2, rtol=1e-6)


def test_im2col_strips_do_not_change_the_result(monkeypatch):
    import spikeref.denoise._conv_alternatives as alternatives

    rng = np.random.default_rng(0)
    x = rng.random((2, 3, 24, 20)).astype(np.float32)
    wt = rng.standard_normal((5, 3, 3, 3)).astype(np.float32)
    b = rng.standard_normal(5).astype(np.float32)
    whole = _conv_im2col(x, wt, b, 0.1)
    monkeypatch.setattr(alternatives, "_STRIP_BYTES", 1)  # one row per strip
    np.testing.assert_allclose(_conv_im2col(x, wt, b, 0.1), whole, rtol=1e-6, atol=1e-7)


def test_network_output_does_not_depend_on_the_thread_count():
    # Each output value of the direct kernel is summed by one job in a fixed order, so unlike
    # BLAS the result is bit for bit the same with one thread or several.
    numba = pytest.importorskip("numba")
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one Numba thread only")
    net = UNet.random(UNetSpec(width=8, depth=3), seed=5)
    x = np.random.default_rng(6).random((3, 40, 56)).astype(np.float32)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = net(x)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = net(x)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one, many)


def test_skip_and_region_read_and_write_what_they_say():
    # conv_padded(xp, skip=s) is the convolution of the concatenation [xp, s], and region=(r, c)
    # writes exactly the interior's first r rows and c columns, bit for bit as the whole layer.
    from spikeref.denoise._unet_kernels import padded_empty
    from spikeref.denoise.conv import conv_padded

    rng = np.random.default_rng(4)
    a = rng.standard_normal((2, 3, 9, 21)).astype(np.float32)
    s = rng.standard_normal((2, 2, 9, 21)).astype(np.float32)
    for cout in (1, 5, 8):  # a lone last channel, a partial group, whole groups
        wt = rng.standard_normal((cout, 5, 3, 3)).astype(np.float32)
        b = rng.standard_normal(cout).astype(np.float32)

        def padded(t):
            out = padded_empty(*t.shape)
            out[:, :, 1:-1, 1:-1] = t
            return out

        whole = conv_padded(padded(np.concatenate([a, s], axis=1)), wt, b, 0.1)
        np.testing.assert_array_equal(whole[:, :, 1:-1, 1:-1], conv3x3(np.concatenate([a, s], axis=1), wt, b, 0.1))
        split = conv_padded(padded(a), wt, b, 0.1, skip=padded(s))
        np.testing.assert_array_equal(split, whole)
        out = padded_empty(2, cout, 9, 21)
        out[:, :, 1:-1, 1:-1] = np.nan
        conv_padded(padded(a), wt, b, 0.1, out=out, skip=padded(s), region=(4, 7))
        np.testing.assert_array_equal(out[:, :, 1:5, 1:8], whole[:, :, 1:5, 1:8])
        assert np.isnan(out[:, :, 5:-1, 1:-1]).all() and np.isnan(out[:, :, 1:-1, 8:-1]).all()


@pytest.mark.parametrize("shape, depth", [((2, 24, 40), 3), ((2, 37, 35), 5)], ids=["whole", "padded"])
def test_every_interior_value_is_written_and_borders_are_zero(monkeypatch, shape, depth):
    # The activations live in buffers from _padded_empty (np.empty inside, zero border): fill
    # the interiors with NaN first, and the network must still give the same finite output.
    # On a padded input the last layers compute only what the output keeps (and the columns up
    # to a multiple of 16): the NaN left in the rest must not reach the output either.
    import spikeref.denoise._unet_kernels as unet

    buf = unet.padded_empty(2, 3, 4, 5)
    assert buf.shape == (2, 3, 6, 7)
    assert not buf[:, :, [0, -1], :].any() and not buf[:, :, :, [0, -1]].any()
    net = UNet.random(UNetSpec(width=6, depth=depth), seed=8)
    x = np.random.default_rng(9).random(shape).astype(np.float32)
    clean = net(x)
    assert np.isfinite(clean).all()
    if depth == 5:  # padded to 64 × 64: the tail computes 48 columns and 37 rows; the oracle every pixel
        np.testing.assert_allclose(clean, unet_forward_oracle(net.params, x, depth=5), rtol=1e-5, atol=1e-6)
    original = unet.padded_empty

    def poisoned(n, c, h, w):
        b = original(n, c, h, w)
        b[:, :, 1:-1, 1:-1] = np.nan
        return b

    monkeypatch.setattr(unet, "padded_empty", poisoned)
    unet.buffers().start(None)  # drop this thread's kept buffers: every buffer is a new, poisoned one
    np.testing.assert_array_equal(net(x), clean)
    # Buffers kept from the pass before are handed out again: poison those too.
    original_take = unet._Buffers.take

    def poisoned_take(self, n, c, h, w):
        b = original_take(self, n, c, h, w)
        b[:, :, 1:-1, 1:-1] = np.nan
        return b

    monkeypatch.setattr(unet._Buffers, "take", poisoned_take)
    np.testing.assert_array_equal(net(x), clean)


def test_kept_buffers_give_the_same_output_and_never_alias_it():
    # A stream of frames of one size reuses the activation buffers of the pass before; the output
    # must be the caller's own array, each pass must equal a pass on fresh buffers, and what is kept
    # stays bounded.
    import spikeref.denoise._unet_kernels as unet

    net = UNet.random(UNetSpec(width=6, depth=3), seed=3)
    rng = np.random.default_rng(4)
    a, b = (rng.random((2, 24, 40)).astype(np.float32) for _ in range(2))
    unet.buffers().start(None)
    fresh_a = net(a)
    unet.buffers().start(None)
    fresh_b = net(b)
    first = net(a)
    kept = {k: len(v) for k, v in unet.buffers().free.items()}
    assert kept and all(n >= 1 for n in kept.values())
    second = net(b)
    np.testing.assert_array_equal(first, fresh_a)
    np.testing.assert_array_equal(second, fresh_b)
    assert {k: len(v) for k, v in unet.buffers().free.items()} == kept  # the same buffers, no more
    first[...] = -1.0  # the output is not a pooled buffer
    np.testing.assert_array_equal(net(b), fresh_b)
    # Two input sizes in turn (the blind and mixed modes alternate 16·N and N images) keep both sets;
    # a third size drops the oldest; release_buffers frees what is kept.
    net(rng.random((1, 8, 16)).astype(np.float32))
    assert all(k[0] == 1 for k in unet.buffers().free)
    assert sorted(unet.buffers().by_size) == [(1, 8, 16), (2, 24, 40)]
    net(a)
    assert {k: len(v) for k, v in unet.buffers().free.items()} == kept  # reused, not made again
    net(rng.random((3, 8, 16)).astype(np.float32))
    assert sorted(unet.buffers().by_size) == [(2, 24, 40), (3, 8, 16)]
    assert unet.release_buffers() > 0 and unet.buffers().nbytes() == 0 and unet.release_buffers() == 0


def test_conv_refuses_bad_arguments():
    x = np.zeros((1, 2, 5, 5), np.float32)
    w = np.zeros((3, 2, 3, 3), np.float32)
    b = np.zeros(3, np.float32)
    with pytest.raises(ValueError, match="x must be"):
        conv3x3(x[0], w, b, None)
    with pytest.raises(ValueError, match="weight must have shape"):
        conv3x3(x, np.zeros((3, 1, 3, 3), np.float32), b, None)
    with pytest.raises(ValueError, match="bias must have shape"):
        conv3x3(x, w, np.zeros(2, np.float32), None)
    with pytest.raises(TypeError, match="x must be floating"):
        conv3x3(x.astype(np.int32), w, b, None)
    with pytest.raises(ValueError, match="slope"):
        conv3x3(x, w, b, 1.5)
    with pytest.raises(TypeError, match="slope"):
        conv3x3(x, w, b, False)
    with pytest.raises(TypeError, match="slope"):
        conv3x3(x, w, b, "0.1")


def test_any_size_is_padded_and_cropped_back():
    net = UNet.random(UNetSpec(width=4, depth=3), seed=1)
    x = np.random.default_rng(2).random((1, 13, 21)).astype(np.float32)
    padded = np.pad(x, ((0, 0), (0, 3), (0, 3)), mode="reflect")  # to 16 × 24
    np.testing.assert_allclose(net(x), net(padded)[:, :13, :21], rtol=1e-6, atol=1e-7)
    assert net(x[0]).shape == (13, 21)
    assert net(np.ones((1, 1), np.float32)).shape == (1, 1)
    assert net(x.astype(np.float64)).dtype == np.float32
    # a thin image reflects along its long side too (a side of 1 repeats), as the oracle does
    thin = x[:, :1, :]
    np.testing.assert_allclose(net(thin), unet_forward_oracle(net.params, thin, depth=3), rtol=1e-5, atol=1e-6)
    wide_padded = np.pad(thin, ((0, 0), (0, 7), (0, 3)), mode="reflect")
    np.testing.assert_allclose(net(thin), net(wide_padded)[:, :1, :21], rtol=1e-6, atol=1e-7)


def test_fast_network_meets_the_golden_oracle_output():
    with np.load(GOLDEN) as z:
        params = {k[len("in_param_"):]: z[k] for k in z.files if k.startswith("in_param_")}
        images, expected = z["in_images"], z["out_output"]
    np.testing.assert_allclose(UNet.from_params(params)(images), expected, rtol=1e-4, atol=1e-5)


def test_pytorch_twin_meets_the_golden_output():
    torch = pytest.importorskip("torch")
    from spikeref.denoise.torch_unet import TorchUNet

    with np.load(GOLDEN) as z:
        params = {k[len("in_param_"):]: z[k] for k in z.files if k.startswith("in_param_")}
        images, expected = z["in_images"], z["out_output"]
    model = TorchUNet(UNetSpec(width=8, depth=5))
    with torch.no_grad():
        for name, conv in model.convs.items():
            conv.weight.copy_(torch.from_numpy(params[f"{name}.weight"]))
            conv.bias.copy_(torch.from_numpy(params[f"{name}.bias"]))
        padded = np.pad(images, ((0, 0), (0, 64 - 37), (0, 64 - 50)), mode="reflect")
        out = model(torch.from_numpy(padded)[:, None])[:, 0, :37, :50].numpy()
    np.testing.assert_allclose(out, expected, rtol=1e-4, atol=1e-5)


def test_exported_pytorch_weights_give_the_same_forward():
    torch = pytest.importorskip("torch")
    from spikeref.denoise.torch_unet import TorchUNet, to_numpy_unet

    torch.manual_seed(4)
    model = TorchUNet(UNetSpec(width=16)).eval()
    x = np.random.default_rng(5).random((3, 64, 96)).astype(np.float32) * 0.3
    with torch.no_grad():
        expected = model(torch.from_numpy(x)[:, None])[:, 0].numpy()
    got = to_numpy_unet(model)(x)
    np.testing.assert_allclose(got, expected, rtol=1e-4, atol=2e-6)


def test_weights_file_round_trip(tmp_path):
    net = UNet.random(UNetSpec(width=6, depth=4, negative_slope=0.2), seed=7)
    net.meta = {"note": "test", "steps": 3}
    path = net.save(tmp_path / "w.npz")
    back = UNet.load(path)
    assert back.spec == net.spec and back.meta == {"note": "test", "steps": 3}
    x = np.random.default_rng(0).random((1, 20, 20)).astype(np.float32)
    np.testing.assert_array_equal(back(x), net(x))
    with np.load(path) as z:
        assert str(z["format"]) == "spikeref-unet-1" and json.loads(str(z["meta"]))["steps"] == 3


def test_bad_weights_and_inputs_are_refused(tmp_path):
    net = UNet.random(UNetSpec(width=4, depth=2))
    with pytest.raises(ValueError, match="batch must have shape"):
        net(np.zeros((1, 1, 4, 4), np.float32))
    with pytest.raises(TypeError, match="floating point"):
        net(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match="finite"):
        net(np.full((4, 4), np.nan, np.float32))
    params = dict(net.params)
    params.pop("tail2.bias")
    with pytest.raises(ValueError, match="tail2.bias"):
        UNet(net.spec, params)
    params = dict(net.params, **{"head0.weight": np.zeros((4, 2, 3, 3), np.float32)})
    with pytest.raises(ValueError, match=r"head0.weight.*shape"):
        UNet(net.spec, params)
    with pytest.raises(ValueError, match="width must be even"):
        UNetSpec(width=5)
    with pytest.raises(FileNotFoundError):
        UNet.load(tmp_path / "none.npz")
    bad = tmp_path / "bad.npz"
    np.savez(bad, format=np.array("other"))
    with pytest.raises(ValueError, match="format"):
        UNet.load(bad)


def test_an_exposure_channel_network_reads_a_constant_second_channel(tmp_path):
    """UNetSpec(in_channels=2): the fast forward, the oracle and the network on a hand-made two-channel input
    agree; the level is required, a one-channel network refuses it, and the file keeps the channel count."""
    spec = UNetSpec(width=8, depth=3, in_channels=2)
    net = UNet.random(spec, seed=4)
    x = np.random.default_rng(5).random((2, 20, 27)).astype(np.float32) * 8
    level = exposure_level(40)
    assert level == pytest.approx(np.log10(40))
    out = net(x, level=level)
    np.testing.assert_allclose(out, unet_forward_oracle(net.params, x, depth=3, level=level), atol=2e-5)
    assert not np.allclose(out, net(x, level=exposure_level(5)), atol=1e-3)  # the channel is read
    # the same as a one-channel-weights view of it when the level's weights are zero
    zeroed = dict(net.params)
    zeroed["head0.weight"] = net.params["head0.weight"].copy()
    zeroed["head0.weight"][:, 1] = 0.0
    one = dict(zeroed, **{"head0.weight": zeroed["head0.weight"][:, :1].copy()})
    np.testing.assert_allclose(UNet.from_params(zeroed)(x, level=3.0), UNet.from_params(one)(x), atol=1e-6)
    assert UNet.from_params(zeroed).spec.in_channels == 2 and layer_shapes(spec)["head0"] == (2, 8)
    with pytest.raises(ValueError, match="exposure channel"):
        net(x)
    with pytest.raises(ValueError, match="finite"):
        net(x, level=float("nan"))
    with pytest.raises(ValueError, match="level= is for"):
        UNet.random(UNetSpec(width=8, depth=3))(x, level=1.0)
    with pytest.raises(ValueError, match="in_channels"):
        UNetSpec(in_channels=3)
    with pytest.raises(ValueError, match="positive"):
        exposure_level(0)
    net.save(tmp_path / "e.npz")
    again = UNet.load(tmp_path / "e.npz")
    assert again.spec == spec
    np.testing.assert_array_equal(again(x, level=level), out)
    UNet.random(UNetSpec(width=8, depth=3), seed=1).save(tmp_path / "one.npz")
    with np.load(tmp_path / "one.npz") as z:
        assert "in_channels" not in z.files  # one-channel files stay as they were
