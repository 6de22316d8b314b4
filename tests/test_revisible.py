"""Eq. 12: the NumPy transcription, its limits, and parity with the PyTorch loss used for training."""

from pathlib import Path

import numpy as np
import pytest

from spikeref.denoise.revisible import lambda_schedule, revisible_loss


def test_hand_computed_value():
    # two pixels, λ = 2, η = 1, worked by hand: re-visible terms 0.25 + 2·0.21 − 3·0.2 = 0.07 and
    # 0.35 + 2·0.39 − 3·0.4 = −0.07, mean of squares 0.0049; regulariser (±0.05)², mean 0.0025
    value = revisible_loss(np.array([0.25, 0.35]), np.array([0.21, 0.39]), np.array([0.2, 0.4]), 2.0)
    assert value == pytest.approx(0.0074, rel=1e-12)
    assert revisible_loss(np.array([0.25, 0.35]), np.array([0.21, 0.39]), np.array([0.2, 0.4]), 2.0,
                          eta=0.0) == pytest.approx(0.0049, rel=1e-12)


def test_torch_loss_reproduces_the_golden_values():
    torch = pytest.importorskip("torch")
    from spikeref.denoise.revisible import revisible_loss_torch

    with np.load(Path(__file__).resolve().parents[1] / "golden" / "eq12_revisible_loss.npz") as z:
        blind, visible, noisy = (torch.tensor(z[f"in_{k}"]) for k in ("blind", "visible", "noisy"))
        settings, expected = z["in_lam_eta"], z["out_loss"]
    got = [float(revisible_loss_torch(blind, visible, noisy, float(lam), float(eta))) for lam, eta in settings]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_literal_values():
    noisy = np.array([[0.2, 0.4], [0.0, 1.0]])
    blind = np.array([[0.25, 0.35], [0.05, 0.9]])
    visible = np.array([[0.21, 0.39], [0.01, 0.98]])
    lam = 2.0
    rev = np.mean([(b + lam * v - 3 * n) ** 2 for b, v, n in zip(blind.ravel(), visible.ravel(), noisy.ravel(),
                                                                   strict=True)])
    reg = np.mean((blind - noisy) ** 2)
    assert revisible_loss(blind, visible, noisy, lam) == pytest.approx(rev + reg, rel=1e-12)
    # a perfect identity network scores 0: why the blind term and stop-gradient matter
    assert revisible_loss(noisy, noisy, noisy, 20.0) == 0.0


def test_schedule_and_errors():
    assert lambda_schedule(0.0) == 2.0 and lambda_schedule(1.0) == 20.0 and lambda_schedule(0.5) == 11.0
    with pytest.raises(ValueError, match="progress"):
        lambda_schedule(1.5)
    with pytest.raises(ValueError, match="one shape"):
        revisible_loss(np.zeros(3), np.zeros(3), np.zeros(4), 2.0)
    with pytest.raises(ValueError, match="finite"):
        revisible_loss(np.full(3, np.nan), np.zeros(3), np.zeros(3), 2.0)
    with pytest.raises(ValueError, match="non-negative"):
        revisible_loss(np.zeros(3), np.zeros(3), np.zeros(3), -1.0)


def test_torch_loss_equals_numpy_and_stops_the_visible_gradient():
    torch = pytest.importorskip("torch")
    from spikeref.denoise.revisible import revisible_loss_torch

    rng = np.random.default_rng(3)
    noisy, blind, visible = (rng.random((2, 1, 8, 8)) for _ in range(3))
    tb = torch.tensor(blind, requires_grad=True)
    tv = torch.tensor(visible, requires_grad=True)
    loss = revisible_loss_torch(tb, tv, torch.tensor(noisy), lam=5.0, eta=1.0)
    assert float(loss.detach()) == pytest.approx(revisible_loss(blind, visible, noisy, 5.0), rel=1e-12)
    loss.backward()
    assert tv.grad is None  # sg(f(I)): no gradient through the visible term
    # dL/dD = 2/N [(D + λf − (λ+1)I) + η(D − I)]
    expected = 2 / noisy.size * ((blind + 5 * visible - 6 * noisy) + (blind - noisy))
    np.testing.assert_allclose(tb.grad.numpy(), expected, rtol=1e-10)
