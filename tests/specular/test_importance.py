"""Importance (S3 §3.2): lightness pipeline, distinctiveness, contrast, against slow references."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import vergence.specular.importance_factors as imp_module
import vergence.specular.lightness as light_module
from vergence.specular import (
    CONTRAST_WINDOW,
    DISTINCTIVENESS_SCALE,
    Importance,
    LayerDisparity,
    PerceivedLightness,
    contrast_q,
    csf_lowpass,
    csf_mannos_sakrison,
    distinctiveness,
    importance,
    layer_disparity,
    lightness_from_srgb,
    peli_contrast,
    perceived_lightness,
    pixels_per_degree,
)
from vergence.viewing import Display

# float64 accumulations of up to 1089 terms of size <= 100^2: relative agreement to 1e-9 is ample.
RTOL = 1e-9
# skimage uses the Y row (0.212671, 0.715160, 0.072169), we the rounded (0.2126, 0.7152, 0.0722): L* differs
# by up to about 0.006 (dY / Y ~ 1e-4); 0.01 ΔL* is a hundredth of a JND.
LAB_ATOL = 0.01
S3_DISPLAY = Display.preset("samsung-2233rz")
# 20 px over 1 cm seen from 1 m: about 35 px per degree, Nyquist 17 cpd, above the CSF peak (8 cpd).
FINE = Display(eye_separation=0.065, distance=1.0, width=0.01)


def lightness_pair(left: np.ndarray, right: np.ndarray) -> PerceivedLightness:
    return PerceivedLightness(left=np.asarray(left, np.float32), right=np.asarray(right, np.float32),
                              exposure=1.0, pixels_per_degree=30.0)  # fmt: skip


def matches_of(disparity: np.ndarray) -> LayerDisparity:
    disparity = np.asarray(disparity, np.float32)
    dist = np.where(np.isnan(disparity[..., 0]), np.nan, 0.0).astype(np.float32)
    return LayerDisparity(disparity_px=disparity, distance=dist, epsilon=1.0, window=(81, 9))


def reference_curvature(left, right, disparity, radius=5, half=1, pixels=None):
    """Per pixel (all, or the ``(n, y, x)`` rows of ``pixels``): S3's 11 x 11 SSD landscape alpha[oy, ox],
    pixel by pixel, then the discrete Hessian at its centre and the Hessian's smaller eigenvalue."""
    n_layers, h, w = left.shape
    out = np.full((n_layers, h, w), np.nan)
    if pixels is None:
        pixels = np.argwhere(np.ones((n_layers, h, w), bool))
    offsets = [(oy, ox) for oy in range(-radius, radius + 1) for ox in range(-radius, radius + 1)]
    u = np.arange(-half, half + 1)
    for n, y, x in pixels:
        dx, dy = disparity[n, y, x]
        if np.isnan(dx):
            continue
        my, mx = y - int(dy), x - int(dx)
        patch = left[n][np.ix_(np.clip(y + u, 0, h - 1), np.clip(x + u, 0, w - 1))].astype(np.float64)
        alpha = []
        for oy, ox in offsets:  # the border pixel repeats outside the image
            other = right[n][np.ix_(np.clip(my + oy + u, 0, h - 1), np.clip(mx + ox + u, 0, w - 1))]
            alpha.append(((patch - other.astype(np.float64)) ** 2).sum())
        a = np.array(alpha).reshape(2 * radius + 1, 2 * radius + 1)
        c = radius
        kxx = a[c, c - 1] - 2 * a[c, c] + a[c, c + 1]
        kyy = a[c - 1, c] - 2 * a[c, c] + a[c + 1, c]
        kxy = (a[c + 1, c + 1] - a[c - 1, c + 1] - a[c + 1, c - 1] + a[c - 1, c - 1]) / 4
        out[n, y, x] = np.linalg.eigvalsh(np.array([[kxx, kxy], [kxy, kyy]]))[0]
    return out


def reference_contrast(image: np.ndarray) -> np.ndarray:
    """Weighted standard deviation in the 17 x 17 Gaussian window, pixel by pixel, borders mirrored."""
    r = 8  # S3: 17 x 17
    u = np.arange(-r, r + 1)
    g1 = np.exp(-0.5 * (u / (r / 3.0)) ** 2)
    g2 = np.outer(g1, g1) / g1.sum() ** 2
    padded = np.pad(image, r, mode="symmetric")  # scipy "reflect" = numpy "symmetric"
    out = np.empty(image.shape)
    for y in range(image.shape[0]):
        for x in range(image.shape[1]):
            patch = padded[y : y + 2 * r + 1, x : x + 2 * r + 1]
            mu = (g2 * patch).sum()
            out[y, x] = np.sqrt((g2 * (patch - mu) ** 2).sum())
    return out


def checkerboard(h: int, w: int, square: int, lo: float = 30.0, hi: float = 70.0) -> np.ndarray:
    ys, xs = np.mgrid[0:h, 0:w]
    return np.where((ys // square + xs // square) % 2 == 0, lo, hi)


# --- lightness pipeline ---------------------------------------------------------------------------


def test_lightness_from_srgb_equals_skimage():
    skimage_color = pytest.importorskip("skimage.color")
    rgb = np.random.default_rng(0).random((7, 9, 3))
    assert_allclose(lightness_from_srgb(rgb), skimage_color.rgb2lab(rgb)[..., 0], atol=LAB_ATOL)


def test_csf_peak_and_pixels_per_degree():
    f = np.linspace(0.1, 40, 40000)
    peak = f[np.argmax(csf_mannos_sakrison(f))]
    assert light_module._csf_peak() == pytest.approx(peak, abs=1e-3)
    assert 7.5 < peak < 8.5  # Mannos & Sakrison: the peak near 8 cpd
    # 1680 px over 0.47376 m at 0.6 m: 1 px = 0.2820 mm = 1.616 arcmin, 37.1 px per degree.
    assert pixels_per_degree(S3_DISPLAY, 1680) == pytest.approx(60 / 1.6158, rel=1e-3)


def test_csf_lowpass_equals_mirrored_fft_reference():
    rng = np.random.default_rng(1)
    img = rng.random((2, 12, 20, 3))
    out = csf_lowpass(img, FINE)
    h, w = 12, 20
    ext = np.concatenate([img, img[:, ::-1]], axis=1)
    ext = np.concatenate([ext, ext[:, :, ::-1]], axis=2)  # even extension, period 2H x 2W
    fy = np.abs(np.fft.fftfreq(2 * h))[:, None]
    fx = np.abs(np.fft.fftfreq(2 * w))[None, :]
    f_cpd = np.hypot(fx, fy) * pixels_per_degree(FINE, w)
    peak = light_module._csf_peak()
    gain = np.where(f_cpd <= peak, 1.0, csf_mannos_sakrison(f_cpd) / csf_mannos_sakrison(peak))
    ref = np.fft.ifft2(np.fft.fft2(ext, axes=(1, 2)) * gain[:, :, None], axes=(1, 2)).real[:, :h, :w]
    assert_allclose(out, ref, atol=1e-12)
    assert np.abs(out - img).max() > 0.05  # pixels fine enough for the CSF to act
    # 4 x 512 px across S3's display: at most 5.7 cpd (even diagonally), below the peak: nothing changes.
    wide = np.random.default_rng(5).random((1, 4, 512, 3))
    assert_array_equal(csf_lowpass(wide, S3_DISPLAY), wide)
    assert_allclose(csf_lowpass(np.full((4, 6, 3), 0.3), FINE), 0.3, atol=1e-12)  # the mean is kept


def test_perceived_lightness_pipeline_and_nan():
    rng = np.random.default_rng(2)
    rad = rng.random((3, 6, 8, 3)) * 4.0
    pos = rng.random((3, 6, 8, 3))
    pos[2, :, :4] = np.nan
    rad_nan = rad.copy()
    rad_nan[2, :, :4] = np.nan  # no surface there: counts as black
    out = perceived_lightness(rad_nan, rad * 0.5, pos, pos, S3_DISPLAY, exposure=0.3)
    from vergence.render import tonemap

    for n in range(3):
        want = lightness_from_srgb(tonemap(np.nan_to_num(rad_nan[n]), exposure=0.3))
        assert_allclose(out.left[n], want, atol=1e-4)  # float32 output
        assert_allclose(out.right[n], lightness_from_srgb(tonemap(rad[n] * 0.5, exposure=0.3)), atol=1e-4)
    assert_array_equal(out.left[2, :, :4], 0.0)
    auto = perceived_lightness(rad, rad, pos, pos, S3_DISPLAY)
    from vergence.render import auto_exposure

    assert auto.exposure == pytest.approx(auto_exposure(rad.sum(axis=0)))
    assert not out.left.flags.writeable


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        (lambda a: a.update(left_radiance=np.zeros((3, 6, 8))), ValueError, r"\(N, H, W, 3\)"),
        (lambda a: a.update(right_radiance=np.zeros((3, 6, 9, 3)), right_position=np.zeros((3, 6, 9, 3))),
         ValueError, "shape of left_radiance"),
        (lambda a: a.update(left_position=np.zeros((2, 6, 8, 3))), ValueError, "left_position must have the shape"),
        (lambda a: a["left_radiance"].__setitem__((0, 0, 0, 0), np.nan), ValueError, "finite where the layer"),
        (lambda a: a["right_radiance"].__setitem__((0, 0, 0, 0), -1.0), ValueError, ">= 0"),
        (lambda a: a["right_radiance"].__setitem__((0, 0, 0, 0), np.inf), ValueError, "inf"),
        (lambda a: a.update(left_radiance=np.full((3, 6, 8, 3), "a")), TypeError, "numeric"),
        (lambda a: a.update(display="phone"), TypeError, "Display"),
        (lambda a: a.update(exposure=0.0), ValueError, "exposure"),
    ],
)
def test_perceived_lightness_bad_input(change, error, match):
    args = {"left_radiance": np.ones((3, 6, 8, 3)), "right_radiance": np.ones((3, 6, 8, 3)),
            "left_position": np.zeros((3, 6, 8, 3)), "right_position": np.zeros((3, 6, 8, 3)),
            "display": S3_DISPLAY, "exposure": None}  # fmt: skip
    change(args)
    exposure = args.pop("exposure")
    kw = {} if exposure is None else {"exposure": exposure}
    with pytest.raises(error, match=match):
        perceived_lightness(*args.values(), **kw)


# --- distinctiveness --------------------------------------------------------------------------------


def test_curvature_of_an_exact_quadratic():
    oy, ox = np.mgrid[-1:2, -1:2].astype(float)
    alpha = 3.0 + 0.5 * ox - oy + 0.5 * (2.0 * ox * ox + 2 * 0.7 * ox * oy + 5.0 * oy * oy)
    assert (imp_module._KAPPA_XX * alpha).sum() == pytest.approx(2.0)
    assert (imp_module._KAPPA_XY * alpha).sum() == pytest.approx(0.7)
    assert (imp_module._KAPPA_YY * alpha).sum() == pytest.approx(5.0)


def test_distinctiveness_equals_reference():
    rng = np.random.default_rng(3)
    shape = (2, 7, 9)
    left = rng.random(shape) * 100
    right = np.roll(left, 2, axis=2) + rng.normal(0, 3, left.shape)
    disp = np.zeros((*shape, 2))
    disp[..., 0] = rng.integers(-3, 4, shape)  # matches near and past the borders
    disp[..., 1] = rng.integers(-1, 2, shape)
    disp[rng.random(shape) < 0.2] = np.nan
    pair, m = lightness_pair(left, right), matches_of(disp)
    factor, lam = distinctiveness(pair, m)
    ref = reference_curvature(pair.left, pair.right, m.disparity_px)
    assert_allclose(lam, ref, rtol=RTOL, atol=1e-9 * np.nanmax(np.abs(ref)))
    assert_array_equal(np.isnan(factor), np.isnan(disp[..., 0]))
    want = 1.0 - np.exp(-np.maximum(ref, 0.0) / DISTINCTIVENESS_SCALE)
    assert_allclose(factor, want, rtol=1e-6, atol=1e-7)


def test_distinctiveness_flat_edge_checkerboard():
    h, w = 24, 24
    zero = np.zeros((1, h, w, 2))
    flat = np.full((1, h, w), 50.0)
    _, lam = distinctiveness(lightness_pair(flat, flat), matches_of(zero))
    assert_array_equal(lam, 0.0)  # a flat image has no curvature at all
    edge = np.where(np.arange(w) < w // 2, 30.0, 70.0)[None, None, :].repeat(h, axis=1)
    _, lam_edge = distinctiveness(lightness_pair(edge, edge), matches_of(zero))
    # A vertical edge slides along itself: the smaller eigenvalue vanishes (aperture problem).
    assert_allclose(lam_edge[0, 8:16, 8:16], 0.0, atol=1e-9)
    for board in (checkerboard(h, w, 1)[None], checkerboard(h, w, 2)[None],
                  np.random.default_rng(6).uniform(30, 70, (1, h, w))):  # fmt: skip
        factor, _ = distinctiveness(lightness_pair(board, board), matches_of(zero))
        assert (factor[0, 4:20, 4:20] > 0.99).all()  # 40 ΔL* structure in both directions: far above the scale
    # Inside the 6 px squares of a coarse checkerboard the 3 x 3 window is flat: no structure to match.
    factor, _ = distinctiveness(lightness_pair(checkerboard(h, w, 8)[None], checkerboard(h, w, 8)[None]),
                                matches_of(zero))  # fmt: skip
    assert_array_equal(factor[0, 2:6, 2:6], 0.0)
    assert (factor[0, 6:10, 6:10] > 0.99).all()  # ... but at its corner, yes


def test_distinctiveness_scale_by_hand():
    # A one-pixel checkerboard of 50 +- 0.5 (1 ΔL* between neighbours): alpha(+-1, 0) = alpha(0, +-1) = 9 x 1^2,
    # alpha(0, 0) = alpha(+-1, +-1) = 0, so k_xx = k_yy = 18, k_xy = 0, lambda_min = 18 = kappa_0: 1 - 1/e.
    board = checkerboard(12, 12, 1, lo=49.5, hi=50.5)[None]
    factor, lam = distinctiveness(lightness_pair(board, board), matches_of(np.zeros((1, 12, 12, 2))))
    assert_allclose(lam[0, 2:-2, 2:-2], 18.0, rtol=1e-12)
    assert_allclose(factor[0, 2:-2, 2:-2], 1.0 - np.exp(-1.0), rtol=1e-6)
    assert DISTINCTIVENESS_SCALE == 18.0
    assert CONTRAST_WINDOW == 17
    half, _ = distinctiveness(lightness_pair(board, board), matches_of(np.zeros((1, 12, 12, 2))), scale=36.0)
    assert_allclose(half[0, 2:-2, 2:-2], 1.0 - np.exp(-0.5), rtol=1e-6)


# --- contrast ---------------------------------------------------------------------------------------


def test_peli_contrast_equals_reference():
    img = np.random.default_rng(4).random((13, 21)) * 100
    assert_allclose(peli_contrast(img), reference_contrast(img), rtol=1e-9, atol=1e-9)
    assert_allclose(peli_contrast(np.full((2, 10, 12), 42.0)), 0.0, atol=1e-6)
    # A fine checkerboard of 30/70 is (almost) uniform under the window: std = 20 ΔL*.
    assert_allclose(peli_contrast(checkerboard(40, 40, 1))[15:25, 15:25], 20.0, rtol=1e-3)


def test_contrast_q():
    c = np.linspace(0.0, 15.0, 151)
    q = contrast_q(c)
    assert q[0] == 0.0 and (q[c >= 10] == 1.0).all()
    assert (np.diff(q) >= 0).all()
    assert_allclose(contrast_q([1.0, 2.5]), [0.028, 0.15625])  # 3t^2 - 2t^3 at t = 0.1, 0.25
    with pytest.raises(ValueError, match=">= 0"):
        contrast_q([-1.0])
    with pytest.raises(ValueError, match="NaN"):
        contrast_q([np.nan])


# --- importance -------------------------------------------------------------------------------------


def test_importance_is_the_product_and_zero_without_match():
    h, w = 20, 24
    board = checkerboard(h, w, 3)[None].repeat(2, axis=0)
    board[1] = 50.0  # the second layer is flat: no contrast, no distinctiveness
    disp = np.zeros((2, h, w, 2))
    disp[0, :, :5] = np.nan
    out = importance(lightness_pair(board, board), matches_of(disp))
    assert isinstance(out, Importance)
    assert_array_equal(out.proximity, ~np.isnan(disp[..., 0]))
    assert_array_equal(out.weight[0, :, :5], 0.0)
    assert_array_equal(out.weight[1], 0.0)
    inner = out.weight[0, 6:14, 8:16]
    assert (inner > 0.9).all()
    m = out.proximity
    assert_allclose(out.weight[m], (out.distinctiveness * out.contrast)[m], rtol=1e-6)
    assert not out.weight.flags.writeable


def test_importance_bad_input():
    pair = lightness_pair(np.zeros((1, 4, 5)), np.zeros((1, 4, 5)))
    with pytest.raises(TypeError, match="PerceivedLightness"):
        importance(np.zeros((1, 4, 5)), matches_of(np.zeros((1, 4, 5, 2))))
    with pytest.raises(TypeError, match="LayerDisparity"):
        importance(pair, np.zeros((1, 4, 5, 2)))
    with pytest.raises(ValueError, match="layers"):
        importance(pair, matches_of(np.zeros((2, 4, 5, 2))))
    with pytest.raises(ValueError, match="scale"):
        importance(pair, matches_of(np.zeros((1, 4, 5, 2))), scale=-1.0)
    with pytest.raises(ValueError, match="lightness"):
        peli_contrast(np.array([[np.nan, 1.0]]))


@pytest.fixture(scope="module")
def glasses():
    render = pytest.importorskip("vergence.render")
    scene = render.open_scene("glasses", width=40, height=30)
    left, right = render.render_stereo(scene, baseline=0.065, convergence=scene.stereo.convergence, max_depth=2,
                                       samples=1)  # fmt: skip
    return left, right


def test_importance_on_glasses(glasses):
    left, right = glasses
    pair = perceived_lightness(left.radiance, right.radiance, left.position, right.position, S3_DISPLAY)
    m = layer_disparity(left.position, right.position)
    out = importance(pair, m)
    assert out.weight.shape == left.radiance.shape[:3]
    assert ((out.weight >= 0) & (out.weight <= 1)).all()
    assert_array_equal(out.weight[~m.matched], 0.0)
    assert (out.weight[0] > 0.1).mean() > 0.05  # the first hit has textured, matched regions
    assert out.weight[1].max() > 0.1  # so has the reflection (the mirror, the glasses' surfaces)
    _, lam = distinctiveness(pair, m)
    idx = np.argwhere(m.matched)[:: max(1, int(m.matched.sum()) // 30)][:30]  # 30 pixels over the layers
    ref = reference_curvature(pair.left, pair.right, m.disparity_px, pixels=idx)[tuple(idx.T)]
    assert_allclose(lam[tuple(idx.T)], ref, rtol=RTOL, atol=1e-9 * np.abs(ref).max())


def test_docstring_examples():
    for module in (imp_module, light_module):
        assert doctest.testmod(module, optionflags=doctest.ELLIPSIS).failed == 0
