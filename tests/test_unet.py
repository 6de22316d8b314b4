"""The NumPy U-Net (spikeref.denoise.unet): convolution, padding, weights files, parity with PyTorch."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spikeref.denoise.unet import UNet, UNetSpec, conv3x3, conv3x3_plain, layer_shapes

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "unet_forward.npz"


def _conv_fast(x, w, b, slope):
    """conv3x3 on channel-first arrays (the layout of conv3x3_plain)."""
    cin, cout = w.shape[1], w.shape[0]
    wmat = np.ascontiguousarray(w.transpose(2, 3, 1, 0).reshape(9 * cin, cout))
    return conv3x3(np.ascontiguousarray(x.transpose(0, 2, 3, 1)), wmat, b, slope).transpose(0, 3, 1, 2)


def test_the_paper_counts_25_convolutions():
    shapes = layer_shapes(UNetSpec(width=32))
    assert len(shapes) == 25  # supplement §8
    assert shapes["head0"] == (1, 32) and shapes["tail2"] == (16, 1) and shapes["dec3a"] == (64, 32)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 2), cin=st.integers(1, 5), cout=st.integers(1, 5), h=st.integers(1, 9),
       w=st.integers(1, 9), slope=st.sampled_from([None, 0.0, 0.1]), seed=st.integers(0, 2**16))
def test_conv_im2col_equals_plain_reference(n, cin, cout, h, w, slope, seed):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, cin, h, w)).astype(np.float32)
    wt = rng.standard_normal((cout, cin, 3, 3)).astype(np.float32)
    b = rng.standard_normal(cout).astype(np.float32)
    np.testing.assert_allclose(_conv_fast(x, wt, b, slope), conv3x3_plain(x, wt, b, slope), rtol=1e-5, atol=1e-5)


def test_conv_known_values():
    # A centre-tap kernel of 2 and bias 1 doubles and shifts; the corner-tap kernel (dy=dx=0)
    # reads the pixel up-left of each output (zero outside): cross-correlation, as PyTorch.
    x = np.arange(12, dtype=np.float32).reshape(1, 1, 3, 4)
    centre = np.zeros((1, 1, 3, 3), np.float32)
    centre[0, 0, 1, 1] = 2.0
    np.testing.assert_array_equal(_conv_fast(x, centre, np.ones(1, np.float32), None), 2 * x + 1)
    corner = np.zeros((1, 1, 3, 3), np.float32)
    corner[0, 0, 0, 0] = 1.0
    expected = np.zeros_like(x)
    expected[..., 1:, 1:] = x[..., :-1, :-1]
    np.testing.assert_array_equal(_conv_fast(x, corner, np.zeros(1, np.float32), None), expected)
    neg = -np.ones((1, 1, 3, 4), np.float32)
    np.testing.assert_allclose(_conv_fast(neg, centre, np.zeros(1, np.float32), 0.1), -0.2, rtol=1e-6)


def test_strips_do_not_change_the_result(monkeypatch):
    import spikeref.denoise.unet as unet

    net = UNet.random(UNetSpec(width=4, depth=2), seed=3)
    x = np.random.default_rng(0).random((2, 24, 20)).astype(np.float32)
    whole = net(x)
    monkeypatch.setattr(unet, "_STRIP_BYTES", 1)  # one row per strip
    np.testing.assert_allclose(net(x), whole, rtol=1e-6, atol=1e-7)


def test_any_size_is_padded_and_cropped_back():
    net = UNet.random(UNetSpec(width=4, depth=3), seed=1)
    x = np.random.default_rng(2).random((1, 13, 21)).astype(np.float32)
    padded = np.pad(x, ((0, 0), (0, 3), (0, 3)), mode="reflect")  # to 16 × 24
    np.testing.assert_allclose(net(x), net(padded)[:, :13, :21], rtol=1e-6, atol=1e-7)
    assert net(x[0]).shape == (13, 21)
    assert net(np.ones((1, 1), np.float32)).shape == (1, 1)
    assert net(x.astype(np.float64)).dtype == np.float32


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
