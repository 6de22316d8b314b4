"""Oracle for the regularised re-visible loss, Eq. 12 (:mod:`spikeref.denoise.revisible`)."""

__all__ = ["revisible_loss_oracle"]


def revisible_loss_oracle(blind, visible, noisy, lam, eta=1.0):
    """Eq. 12 pixel by pixel, in Python floats.

    ``L_r = (1/N) Σ_x (D(x) + λ f(x) − (λ + 1) I(x))² + η (1/N) Σ_x (D(x) − I(x))²``.
    Each squared norm is a mean over the ``N`` pixels (docs/spec/denoise.md). ``f`` is the visible
    output; the stop-gradient changes no value, only the gradient, so it does not appear here.
    """
    d = [float(v) for v in blind.ravel()]
    f = [float(v) for v in visible.ravel()]
    i = [float(v) for v in noisy.ravel()]
    n = len(d)
    rev = 0.0
    reg = 0.0
    for x in range(n):
        rev += (d[x] + lam * f[x] - (lam + 1.0) * i[x]) ** 2
        reg += (d[x] - i[x]) ** 2
    return rev / n + eta * (reg / n)
