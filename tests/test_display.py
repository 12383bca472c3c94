"""Stereo pair layouts: exact pixel placement on tiny images, Dubois by hand, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from vergence.display import ANAGLYPH_METHODS, anaglyph, checkerboard, interleave, side_by_side, tile_views, top_bottom

# Float64 arithmetic of the same formulas, compared in float32: a few float32 ulps.
FLOAT32_TOL = 1e-6

# Dubois 2009 red-cyan matrices, typed again from the note (rows = output R, G, B).
M_LEFT = [[0.437, 0.449, 0.164], [-0.062, -0.062, -0.024], [-0.048, -0.050, -0.017]]
M_RIGHT = [[-0.011, -0.032, -0.007], [0.377, 0.761, 0.009], [-0.026, -0.093, 1.234]]


def _encode(v: float) -> float:
    """sRGB encoding (IEC 61966-2-1) of one linear value in [0, 1]."""
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def _views(shape=(2, 3)):
    """Left 0.1 * (1 + index), right 0.5 + 0.01 * index: every pixel distinct and traceable."""
    n = int(np.prod(shape))
    left = (np.arange(n).reshape(shape) + 1) * 0.1 / n
    right = 0.5 + 0.01 * np.arange(n).reshape(shape)
    return left.astype(np.float32), right.astype(np.float32)


# --- anaglyphs ---------------------------------------------------------------------------------


def test_red_cyan_takes_red_from_left_and_green_blue_from_right():
    left = np.array([[[0.9, 0.1, 0.2]]])
    right = np.array([[[0.3, 0.6, 0.7]]])
    assert_array_equal(anaglyph(left, right, method="red-cyan"), np.float32([[[0.9, 0.6, 0.7]]]))


def test_grey_views_are_replicated_for_anaglyphs():
    left, right = np.array([[0.25]]), np.array([[0.75]])
    assert_array_equal(anaglyph(left, right, method="red-cyan"), np.float32([[[0.25, 0.75, 0.75]]]))
    out = anaglyph(left, right, method="half-color")
    assert out.shape == (1, 1, 3)
    assert_allclose(out, [[[0.25, 0.75, 0.75]]], atol=FLOAT32_TOL)  # luma of a grey is the grey


def test_half_color_uses_rec601_luma_of_the_left_view():
    left = np.array([[[1.0, 0.0, 0.0], [0.2, 0.4, 0.6]]])
    right = np.array([[[0.0, 0.5, 1.0], [0.1, 0.2, 0.3]]])
    expected = [[[0.299, 0.5, 1.0], [0.299 * 0.2 + 0.587 * 0.4 + 0.114 * 0.6, 0.2, 0.3]]]
    assert_allclose(anaglyph(left, right, method="half-color"), expected, atol=FLOAT32_TOL)


@pytest.mark.parametrize(
    ("left", "right", "linear"),
    [
        # pure red on the left, black on the right: the first column of M_L, clipped at 0
        ((1, 0, 0), (0, 0, 0), (0.437, 0.0, 0.0)),
        # pure green on the right: the second column of M_R
        ((0, 0, 0), (0, 1, 0), (0.0, 0.761, 0.0)),
        # pure blue on the right: third column of M_R, blue clipped at 1
        ((0, 0, 0), (0, 0, 1), (0.0, 0.009, 1.0)),
        # white on both sides: the row sums of M_L + M_R
        ((1, 1, 1), (1, 1, 1), (1.050 - 0.050, -0.148 + 1.147, -0.115 + 1.115)),
        # red left, cyan right
        ((1, 0, 0), (0, 1, 1), (0.437 - 0.039, -0.062 + 0.770, -0.048 + 1.141)),
    ],
)
def test_dubois_on_pure_colours_by_hand(left, right, linear):
    expected = [_encode(min(max(v, 0.0), 1.0)) for v in linear]
    out = anaglyph(np.array([[left]], float), np.array([[right]], float), method="dubois")
    assert_allclose(out[0, 0], expected, atol=FLOAT32_TOL)


# Issue 9: iw3 offers seven anaglyph kinds; so does ANAGLYPH_METHODS. Green-magenta and amber-blue
# Dubois matrices, typed again from Dubois's anaglyph web page (rows = output R, G, B).
M_GREEN_MAGENTA = (
    [[-0.062, -0.158, -0.039], [0.284, 0.668, 0.143], [-0.015, -0.027, 0.021]],
    [[0.529, 0.705, 0.024], [-0.016, -0.015, -0.065], [0.009, 0.075, 0.937]],
)
M_AMBER_BLUE = (
    [[1.062, -0.205, 0.299], [-0.026, 0.908, 0.068], [-0.038, -0.173, 0.022]],
    [[-0.016, -0.123, -0.017], [0.006, 0.062, -0.017], [0.094, 0.185, 0.911]],
)


def test_seven_anaglyph_methods():
    assert list(ANAGLYPH_METHODS) == [
        "amber-blue", "dubois", "dubois-amber-blue", "dubois-green-magenta", "green-magenta", "half-color", "red-cyan",
    ]
    left = np.array([[[0.9, 0.2, 0.3]]], np.float32)
    right = np.array([[[0.4, 0.6, 0.7]]], np.float32)
    # Plain anaglyphs by hand: the left eye's filter passes the left view's channels.
    assert_array_equal(anaglyph(left, right, method="green-magenta"), np.float32([[[0.4, 0.2, 0.7]]]))
    assert_array_equal(anaglyph(left, right, method="amber-blue"), np.float32([[[0.9, 0.2, 0.7]]]))


@pytest.mark.parametrize(("method", "matrices"), [("dubois-green-magenta", M_GREEN_MAGENTA), ("dubois-amber-blue", M_AMBER_BLUE)])
@pytest.mark.parametrize(("left", "right"), [((1, 0, 0), (0, 0, 0)), ((0, 0, 0), (0, 1, 0)), ((0.5, 0.5, 0.5), (0.2, 0.9, 0.4))])
def test_dubois_green_magenta_and_amber_blue_by_hand(method, matrices, left, right):
    def linear(v):
        return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4

    m_left, m_right = matrices
    expected = [
        _encode(min(max(sum(ml[c] * linear(left[c]) + mr[c] * linear(right[c]) for c in range(3)), 0.0), 1.0))
        for ml, mr in zip(m_left, m_right, strict=True)
    ]
    out = anaglyph(np.array([[left]], float), np.array([[right]], float), method=method)
    assert_allclose(out[0, 0], expected, atol=FLOAT32_TOL)


def _dubois_reference(left, right, m_left, m_right):
    """Dubois in float64 numpy, the sRGB curves (IEC 61966-2-1) computed, not tabulated."""
    def decode(v):
        return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)

    lin = decode(left.astype(float)) @ np.asarray(m_left).T + decode(right.astype(float)) @ np.asarray(m_right).T
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.maximum(lin, 0.0031308) ** (1 / 2.4) - 0.055)


# The kernel's tabulated sRGB curves: error <= 3.3e-8 through the matrices (vergence._display_kernels), then
# float32 rounding of the result (3e-8 at 0.5 to 1). Measured 3.1e-8 at most on 10^5 random pixels.
DUBOIS_TABLE_TOL = 6e-8


@pytest.mark.parametrize(("method", "matrices"), [("dubois", (M_LEFT, M_RIGHT)),
                                                  ("dubois-green-magenta", M_GREEN_MAGENTA),
                                                  ("dubois-amber-blue", M_AMBER_BLUE)])  # fmt: skip
def test_dubois_kernel_matches_the_float64_formula(method, matrices):
    rng = np.random.default_rng(5)
    left, right = rng.uniform(0, 1, (2, 200, 500, 3)).astype(np.float32)
    left[0, :20] = np.linspace(0.0, 0.08, 60, dtype=np.float32).reshape(20, 3)  # around the kink at 0.04045
    right[0, :4] = np.array([0.0, 1e-3, 0.04045, 1.0])[:, None]
    out = anaglyph(left, right, method=method)
    expected = _dubois_reference(left, right, *matrices)
    assert np.abs(out - expected).max() > 0  # the tables are not the formula
    assert_allclose(out, expected, atol=DUBOIS_TABLE_TOL, rtol=0)


@pytest.mark.parametrize("method", ["dubois", "dubois-green-magenta", "dubois-amber-blue"])
def test_a_white_pair_stays_white_within_the_matrices_rounding(method):
    # Each matrix pair's row sums are 1 within 0.001 (three printed decimals): white stays white.
    out = anaglyph(np.ones((1, 1, 3)), np.ones((1, 1, 3)), method=method)
    assert_allclose(out[0, 0], 1.0, atol=2e-3)


def test_dubois_works_in_linear_light():
    grey = 0.5  # sRGB 0.5 is linear 0.21404
    lin = ((grey + 0.055) / 1.055) ** 2.4
    assert abs(lin - 0.21404) < 1e-5
    rows = zip(M_LEFT, M_RIGHT, strict=True)
    expected = [_encode(min(max(lin * (sum(ml) + sum(mr)), 0.0), 1.0)) for ml, mr in rows]
    out = anaglyph(np.full((1, 1), grey), np.full((1, 1), grey))  # dubois is the default
    assert_allclose(out[0, 0], expected, atol=FLOAT32_TOL)


def test_anaglyph_shapes_dtype_and_uint8_input():
    left = np.zeros((4, 5, 3), np.uint8)
    right = np.full((4, 5, 3), 255, np.uint8)
    for method in ANAGLYPH_METHODS:
        out = anaglyph(left, right, method=method)
        assert out.shape == (4, 5, 3) and out.dtype == np.float32
        assert out.min() >= 0 and out.max() <= 1


def test_anaglyph_bad_input():
    a = np.zeros((2, 2, 3))
    with pytest.raises(ValueError, match="method must be one of amber-blue, dubois, dubois-amber-blue, dubois-green-magenta, green-magenta, half-color, red-cyan; got 'green'"):
        anaglyph(a, a, method="green")
    with pytest.raises(ValueError, match=r"right must have the same shape as left \(2, 2, 3\); got \(2, 3, 3\)"):
        anaglyph(a, np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match=r"right must have the same shape as left \(2, 2, 3\); got \(2, 2\)"):
        anaglyph(a, np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"left must have shape \(H, W\) or \(H, W, 3\); got \(2, 2, 4\) \(no alpha"):
        anaglyph(np.zeros((2, 2, 4)), np.zeros((2, 2, 4)))
    with pytest.raises(ValueError, match=r"right values must lie in \[0, 1\]; got \[0, 2\]"):
        anaglyph(a, a + 2 * (np.arange(3) == 1))
    with pytest.raises(ValueError, match="left must be finite"):
        anaglyph(np.full((2, 2), np.nan), np.zeros((2, 2)))


# --- frame packing -----------------------------------------------------------------------------


def test_side_by_side_and_top_bottom_full():
    left, right = _views((2, 3))
    sbs = side_by_side(left, right)
    assert sbs.shape == (2, 6)
    assert_array_equal(sbs[:, :3], left)
    assert_array_equal(sbs[:, 3:], right)
    tb = top_bottom(left[..., None].repeat(3, 2), right[..., None].repeat(3, 2))
    assert tb.shape == (4, 3, 3)
    assert_array_equal(tb[:2, :, 1], left)
    assert_array_equal(tb[2:, :, 1], right)


def test_half_side_by_side_averages_column_pairs():
    left = np.array([[0.0, 0.5, 1.0, 1.0], [0.2, 0.4, 0.0, 0.0]])
    right = np.array([[1.0, 1.0, 0.0, 0.25], [0.5, 0.5, 0.5, 0.5]])
    out = side_by_side(left, right, half=True)
    assert out.shape == (2, 4)
    assert_allclose(out, [[0.25, 1.0, 1.0, 0.125], [0.3, 0.0, 0.5, 0.5]], atol=FLOAT32_TOL)


def test_half_side_by_side_odd_width_uses_area_weights():
    row = np.array([[0.0, 0.0, 1.0, 1.0, 1.0]])  # 5 -> 2 columns: weights (1, 1, 0.5) / 2.5
    out = side_by_side(row, row, half=True)
    assert out.shape == (1, 4)
    assert_allclose(out, [[0.2, 1.0, 0.2, 1.0]], atol=FLOAT32_TOL)


def test_half_top_bottom_averages_row_pairs_in_colour():
    left = np.zeros((4, 1, 3))
    left[1] = 1.0  # rows 0, 1 average to 0.5; rows 2, 3 to 0
    right = np.full((4, 1, 3), 0.75)
    out = top_bottom(left, right, half=True)
    assert out.shape == (4, 1, 3)
    assert_allclose(out[:, 0, 0], [0.5, 0.0, 0.75, 0.75], atol=FLOAT32_TOL)


def test_half_needs_two_pixels_and_a_bool():
    one = np.zeros((3, 1))
    with pytest.raises(ValueError, match="at least 2 pixels wide for half side-by-side; got width 1"):
        side_by_side(one, one, half=True)
    with pytest.raises(ValueError, match="at least 2 pixels high for half top-bottom; got height 1"):
        top_bottom(one.T, one.T, half=True)
    with pytest.raises(TypeError, match="half must be a bool; got int"):
        side_by_side(one, one, half=1)
    with pytest.raises(TypeError, match="half must be a bool; got str"):
        top_bottom(one, one, half="yes")


# --- interleaving ------------------------------------------------------------------------------


def test_row_and_column_interleave():
    left, right = _views((3, 4))
    rows = interleave(left, right)
    assert_array_equal(rows[[0, 2]], left[[0, 2]])
    assert_array_equal(rows[1], right[1])
    cols = interleave(left, right, orientation="columns")
    assert_array_equal(cols[:, [0, 2]], left[:, [0, 2]])
    assert_array_equal(cols[:, [1, 3]], right[:, [1, 3]])
    with pytest.raises(ValueError, match="orientation must be one of columns, rows; got 'diagonal'"):
        interleave(left, right, orientation="diagonal")


def test_checkerboard_parity():
    left, right = _views((3, 3))
    out = checkerboard(np.stack([left] * 3, 2), np.stack([right] * 3, 2))
    for y in range(3):
        for x in range(3):
            expected = left[y, x] if (x + y) % 2 == 0 else right[y, x]
            assert_array_equal(out[y, x], [expected] * 3)


def test_inputs_are_not_modified():
    left, right = _views((2, 4))
    lc, rc = left.copy(), right.copy()
    for f in (side_by_side, top_bottom, interleave, checkerboard, anaglyph):
        f(left, right)
    side_by_side(left, right, half=True)
    assert_array_equal(left, lc)
    assert_array_equal(right, rc)


@pytest.mark.parametrize("method", list(ANAGLYPH_METHODS))
@pytest.mark.parametrize("shape", [(2, 4), (2, 4, 3)])
def test_anaglyph_reads_float32_views_without_copying_them_and_returns_a_new_image(method, shape):
    # anaglyph validates float32 views without a copy (the StereoSpace pair's packing): no method
    # may write into them or hand one of them back
    left, right = _views(shape)
    lc, rc = left.copy(), right.copy()
    out = anaglyph(left, right, method=method)
    out[...] = 0.25
    assert not np.shares_memory(out, left) and not np.shares_memory(out, right)
    assert_array_equal(left, lc)
    assert_array_equal(right, rc)


# --- tiles -------------------------------------------------------------------------------------


def test_tile_views_places_views_row_by_row():
    views = [np.full((2, 3), 0.1 * (i + 1)) for i in range(5)]
    out = tile_views(views)  # ceil(sqrt(5)) = 3 columns, 2 rows
    assert out.shape == (4, 9)
    for i in range(5):
        r, c = divmod(i, 3)
        assert_allclose(out[2 * r : 2 * r + 2, 3 * c : 3 * c + 3], 0.1 * (i + 1), atol=FLOAT32_TOL)
    assert_array_equal(out[2:, 6:], 0.0)  # the empty cell is black
    column = tile_views(views[:2], columns=1)
    assert column.shape == (4, 3)
    assert tile_views([np.zeros((2, 2, 3))]).shape == (2, 2, 3)


def test_tile_views_bad_input():
    with pytest.raises(ValueError, match="views must hold at least one view; got 0"):
        tile_views([])
    with pytest.raises(TypeError, match="views must be a sequence"):
        tile_views(np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match=r"views\[1\] must have the shape of views\[0\] \(2, 2\); got \(2, 3\)"):
        tile_views([np.zeros((2, 2)), np.zeros((2, 3))])
    with pytest.raises(ValueError, match="columns must be >= 1; got 0"):
        tile_views([np.zeros((2, 2))], columns=0)
    with pytest.raises(TypeError, match="columns must be an integer; got float"):
        tile_views([np.zeros((2, 2))], columns=2.0)
    with pytest.raises(ValueError, match=r"views\[0\] values must lie in \[0, 1\]"):
        tile_views([np.full((2, 2), 3.0)])


# ---------------------------------------------------------------------------------- pack


def test_pack_dispatches_every_layout_of_the_table():
    from vergence.display import LAYOUTS, pack

    left = np.zeros((2, 4, 3), np.float32)
    right = np.ones((2, 4, 3), np.float32)
    shapes = {
        "sbs": (2, 8, 3), "half-sbs": (2, 4, 3), "tb": (4, 4, 3), "half-tb": (2, 4, 3), "cross-eyed": (2, 8, 3),
        "rows": (2, 4, 3), "columns": (2, 4, 3), "checkerboard": (2, 4, 3),
        "anaglyph": (2, 4, 3), **{f"anaglyph-{m}": (2, 4, 3) for m in ANAGLYPH_METHODS if m != "dubois"},
    }
    assert set(LAYOUTS) == set(shapes)
    for name, shape in shapes.items():
        assert pack(left, right, layout=name).shape == shape, name
    # Cross-eyed free viewing: the right view on the left.
    assert pack(left, right, layout="cross-eyed")[0, :4].min() == 1.0
    assert_array_equal(pack(left, right, layout="columns"), interleave(left, right, orientation="columns"))
    assert_array_equal(pack(left, right, layout="anaglyph-red-cyan"), anaglyph(left, right, method="red-cyan"))


def test_pack_refuses_an_unknown_layout_and_lists_the_valid_ones():
    from vergence.display import LAYOUTS, pack

    with pytest.raises(ValueError, match="layout must be one of " + ", ".join(LAYOUTS) + "; got 'gif'"):
        pack(np.zeros((2, 2)), np.zeros((2, 2)), layout="gif")
    with pytest.raises(TypeError):
        LAYOUTS["gif"] = None  # read-only table
