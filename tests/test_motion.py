"""Parametric motion (spikeref.simulate.motion) and the exact flow of the image scenes."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm
from scipy.ndimage import map_coordinates

from spikeref.simulate.motion import Motion, layer_flow, plane_flow, plane_grid_points
from spikeref.simulate.scenes import ImageMotion, TranslatingTexture, Uniform


def _texture(h=96, w=120, seed=0):
    """A smooth random radiance image (Gaussian-filtered noise), so resampling is accurate."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    img = gaussian_filter(rng.random((h, w, 3)), (2.5, 2.5, 0))
    img = (img - img.min()) / (img.max() - img.min())
    return (0.05 + 0.5 * img).astype(np.float32)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=4, max_size=4), st.floats(-2, 2))
def test_matrix_is_the_exact_exponential(g, t):
    m = Motion(affine=((g[0], g[1]), (g[2], g[3])), center=(0, 0))
    np.testing.assert_allclose(m.matrix(t), expm(np.array([[g[0], g[1]], [g[2], g[3]]]) * t), rtol=1e-9, atol=1e-9)


def test_rotation_turns_clockwise_on_screen_about_its_centre():
    m = Motion(rotation=90.0, center=(10.0, 20.0))  # a quarter turn per second
    # +x goes to +y (downwards): clockwise on a screen whose rows grow downwards
    np.testing.assert_allclose(m.forward(np.array([13.0, 20.0]), 1.0), [10.0, 23.0], atol=1e-12)
    np.testing.assert_allclose(m.forward(np.array([10.0, 20.0]), 0.7), [10.0, 20.0], atol=1e-12)


def test_zoom_scales_by_exp_rate_and_translation_adds():
    m = Motion(zoom=math.log(2.0), velocity=(3.0, -1.0), center=(0.0, 0.0))
    np.testing.assert_allclose(m.forward(np.array([1.0, 2.0]), 1.0), [2.0 + 3.0, 4.0 - 1.0], atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.floats(-50, 50), st.floats(-2, 2), st.floats(-400, 400), st.floats(-0.02, 0.02))
def test_forward_inverts_inverse(rot, zoom, vx, t):
    m = Motion(velocity=(vx, 0.5 * vx), rotation=rot, zoom=zoom, center=(30.0, 40.0))
    p = np.random.default_rng(0).random((20, 2)) * 100
    np.testing.assert_allclose(m.forward(m.inverse(p, t), t), p, atol=1e-9)
    # flows compose: t0 → t1 → t2 equals t0 → t2
    f01 = layer_flow(m, p, 0.001, t)
    f12 = layer_flow(m, p + f01, t, -0.003)
    np.testing.assert_allclose(f01 + f12, layer_flow(m, p, 0.001, -0.003), atol=1e-9)


@pytest.mark.parametrize("bad, match", [
    ({"velocity": (1.0,)}, "motion.velocity must be two numbers"),
    ({"rotation": float("nan")}, "motion.rotation must be a finite number"),
    ({"affine": ((1, 2), (3,))}, "motion.affine must be a 2×2 matrix"),
    ({"zoom": True}, "motion.zoom must be a finite number"),
])
def test_bad_motion(bad, match):
    with pytest.raises(ValueError, match=match):
        Motion(**bad)


def test_motion_table_names_the_field():
    with pytest.raises(ValueError, match="unknown field content.motion.speed"):
        Motion.from_table({"speed": 3}, "content.motion")
    with pytest.raises(ValueError, match="content.foreground.motion.rotation"):
        Motion.from_table({"rotation": "fast"}, "content.foreground.motion")
    m = Motion(velocity=(1, 2), rotation=3, center=(4, 5))
    assert Motion.from_table(m.to_table()) == m


def test_plane_grid_points():
    p = plane_grid_points(4, 6)
    assert p.shape == (2, 3, 2)
    np.testing.assert_array_equal(p[1, 2], [4.5, 2.5])  # cell (1, 2): pixels rows 2-3, cols 4-5
    np.testing.assert_array_equal(plane_grid_points(4, 6, (1, 0))[1, 2], [4.0, 3.0])


@pytest.mark.parametrize("motion, fg", [
    (Motion(velocity=(1500.0, -700.0)), False),
    (Motion(rotation=900.0, zoom=4.0), False),
    (Motion(affine=((5.0, 8.0), (-3.0, -2.0)), velocity=(600.0, 0.0)), False),
    (Motion(velocity=(-900.0, 0.0)), True),
])
def test_true_flow_warps_the_later_frame_onto_the_earlier(motion, fg):
    """Sampling the frame at t1 at x + F(x) reproduces the frame at t0; zero or reversed flow does not."""
    kw = {}
    if fg:
        kw = dict(fg_image=_texture(60, 60, seed=1)[..., ::-1] * 1.5, fg_radius=18.0, fg_center=(40.0, 30.0),
                  fg_motion=Motion(velocity=(2500.0, 800.0)))
    content = ImageMotion(image=_texture(), height=64, width=80, motion=motion, **kw)
    t0, t1 = 100.0, 140.0
    r0, r1 = content.radiance([t0, t1])
    flow, visible = content.true_flow(t0, t1)
    assert flow.shape == (64, 80, 2) and visible.dtype == bool
    inner = np.zeros((64, 80), bool)
    inner[6:-6, 6:-6] = True
    inner &= visible

    def err(f):
        pts = content._view_points + f
        warped = np.stack([map_coordinates(r1[..., c], [pts[..., 1], pts[..., 0]], order=1, mode="nearest")
                           for c in range(3)], axis=-1)
        return float(np.abs(warped - r0)[inner].mean())

    good = err(flow)
    assert good < 0.25 * err(np.zeros_like(flow))
    assert good < 0.25 * err(-flow)
    assert np.abs(flow).max() > 0.5  # the motion is large enough for the test to mean something
    if fg:
        assert 0 < (~visible[6:-6, 6:-6]).sum() < 0.2 * visible.size  # the disc hides some background


def test_plane_flow_is_dy_dx_in_plane_pixels():
    content = TranslatingTexture(height=32, width=48, velocity=(2000.0, -600.0), texture_size=16)
    flow, visible = plane_flow(content, 50, 60)  # 10 readouts: (1, -0.3) px = (0.5, -0.15) plane px
    assert flow.shape == (2, 16, 24) and flow.dtype == np.float32
    np.testing.assert_allclose(flow[0], -0.15, atol=1e-6)
    np.testing.assert_allclose(flow[1], 0.5, atol=1e-6)
    assert visible.all()
    still, vis = plane_flow(Uniform(height=8, width=8), 0, 100)
    assert not still.any() and vis.all()


def test_image_content_checks_its_arrays():
    with pytest.raises(ValueError, match="content.image must have shape"):
        ImageMotion(image=np.zeros((4, 4)), height=4, width=4)
    with pytest.raises(ValueError, match="finite and ≥ 0"):
        ImageMotion(image=-np.ones((4, 4, 3)), height=4, width=4)
    with pytest.raises(ValueError, match="without a foreground image"):
        ImageMotion(image=np.ones((4, 4, 3)), height=4, width=4, fg_radius=3.0)
    c = ImageMotion(image=np.ones((4, 4, 3)), height=4, width=4)
    assert c.static and c.radiance([0.0, 5.0]).shape == (2, 4, 4, 3)
