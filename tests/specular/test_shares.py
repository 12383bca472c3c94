"""Plain and importance-weighted zone shares per layer and per object (issue 26), the display fit, and
the offset table kept on disk: hand-worked cases and round trips."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.specular import (
    DISPLAY_FITS,
    LayerState,
    arcmin_per_pixel,
    display_block,
    fit_display,
    object_shares,
    zone_count,
    zone_warnings,
)
from vergence.viewing import ComfortZone, Display

STUDY = Display.preset("samsung-2233rz")
ZONE = ComfortZone()  # +-60'
# arcmin_per_pixel is 2 atan(p / 2D): the screen/native ratio differs from the pitch ratio by the
# atan's curvature, (x^2 / 3) with x = p / 2D < 0.01 here: below 4e-5 relative
ATAN_RTOL = 1e-4


@pytest.mark.parametrize("width", [48, 320, 1680, 3000])
def test_native_and_screen_differ_by_the_screen_width_over_the_image_width(width):
    screen = arcmin_per_pixel(fit_display(STUDY, width, fit="screen"))
    native = arcmin_per_pixel(fit_display(STUDY, width, fit="native"))
    assert screen / native == pytest.approx(STUDY.resolution / width, rel=ATAN_RTOL)
    # S3 §4: the study display shows one of its pixels as about 1.62'
    assert native == pytest.approx(1.62, abs=0.01)


def test_the_issues_figures_for_a_320_px_image():
    # issue 26: "the 320-px image stretched over the 1680-px screen: 8.48' per image pixel", native 1.62'
    block = display_block(STUDY, 320, fit="screen")
    assert block["arcmin_per_px"] == pytest.approx(8.48, abs=0.005)
    assert block["name"] == "samsung-2233rz" and block["fit"] == "screen"
    assert block["screen_px_per_image_px"] == pytest.approx(5.25)
    native = display_block(STUDY, 320, fit="native")
    assert native["arcmin_per_px"] == pytest.approx(1.616, abs=0.001)
    assert native["shown_width_m"] == pytest.approx(320 * STUDY.pixel_pitch)
    assert display_block(Display(0.065, 1.0, 0.5, resolution=1000), 100, fit="native")["name"] is None


def test_a_bad_fit_is_refused_with_the_valid_fits():
    with pytest.raises(ValueError, match="fit must be one of screen, native; got 'wide'"):
        fit_display(STUDY, 320, fit="wide")
    with pytest.raises(ValueError, match="width_px must be an integer >= 1"):
        fit_display(STUDY, 0)
    with pytest.raises(ValueError, match="resolution"):
        fit_display(Display(0.065, 0.6, 0.47), 320)
    assert DISPLAY_FITS[0] == "screen"  # the default of vergence specular --fit


def _state(dx: list[list[float]], w: list[list[float]]) -> LayerState:
    """Two layers of a 1 x 4 image: horizontal disparities (NaN: no match) and importances."""
    d = np.zeros((2, 1, 4, 2), np.float32)
    d[..., 0] = np.array(dx, np.float32)[:, None, :]
    d[np.isnan(d[..., 0])] = np.nan
    imp = np.array(w, np.float32)[:, None, :]
    return LayerState(disparity=d, importance=imp, rivalry=np.zeros((2, 1, 4), np.float32),
                      present=np.ones((2, 1, 4), bool))  # fmt: skip


def test_zone_count_by_hand():
    state = _state([[0.0, 70.0, -50.0, np.nan], [200.0, 10.0, 300.0, 61.0]], [[1, 1, 2, 5], [0.0, 0.5, 0.0, 0.0]])
    count = zone_count(state, ZONE)
    np.testing.assert_array_equal(count.matched, [3, 4])
    np.testing.assert_array_equal(count.inside, [2, 1])  # 0' and -50'; 10'
    np.testing.assert_allclose(count.share(), [2 / 3, 1 / 4])
    np.testing.assert_allclose(count.weighted_share(), [3 / 4, 1.0])  # the unmatched weight 5 does not count
    # layer 2: 1 of 4 inside, but its only important pixel is: weighted 100 %, plain 25 %
    assert count.share(slice(0, 2)) == pytest.approx(3 / 7)
    masked = zone_count(state, ZONE, np.array([[False, True, True, True]]))
    np.testing.assert_array_equal(masked.matched, [2, 3])
    np.testing.assert_array_equal(masked.inside, [1, 1])
    with pytest.raises(ValueError, match="mask must be a bool array of shape"):
        zone_count(state, ZONE, np.ones((1, 3), bool))


def test_object_shares_and_warnings_by_hand():
    # pixels 0-1 see a mirror (object 4), pixels 2-3 a glass ball (object 7); layer 2 is what they show
    first = np.array([[4, 4, 7, 7]])
    objects = [{"object": 4, "name": "mirror", "type": "mirror", "shape": "rectangle"},
               {"object": 7, "name": "ball", "type": "glass", "shape": "sphere"},
               {"object": 9, "name": "unseen", "type": "glass", "shape": "sphere"}]  # fmt: skip
    before = _state([[0.0, 0.0, 0.0, 0.0], [300.0, 250.0, 80.0, 20.0]], [[1, 1, 1, 1], [1, 1, 1, 1]])
    after = _state([[0.0, 0.0, 0.0, 0.0], [200.0, 55.0, 40.0, 20.0]], [[1, 1, 1, 1], [0.0, 1.0, 1.0, 1.0]])
    shares = object_shares(before, after, first, objects, ZONE, ["first hit", "R"])
    assert [s["name"] for s in shares] == ["mirror", "ball"]  # the unseen object is left out
    mirror, ball = shares
    assert mirror["pixels"] == 2 and mirror["matched_before"] == 2 and mirror["inside_before"] == 0
    assert mirror["inside_after"] == 1 and mirror["inside_share_after"] == 0.5
    # the mirror's pixel still at 200' lost its importance: weighted, the mirror looks all inside
    assert mirror["comfort_share_after"] == 1.0
    assert ball["inside_share_before"] == 0.5 and ball["inside_share_after"] == 1.0
    assert [row["layer"] for row in mirror["layers"]] == [2]
    assert zone_warnings(shares, ZONE) == []  # 50 % is not "mostly outside"
    after_bad = _state([[0.0, 0.0, 0.0, 0.0], [200.0, 155.0, 40.0, 20.0]], [[1, 1, 1, 1], [1, 1, 1, 1]])
    lines = zone_warnings(object_shares(before, after_bad, first, objects, ZONE, ["first hit", "R"]), ZONE)
    assert len(lines) == 1 and "mirror 'mirror' (objects[4], rectangle)" in lines[0]
    assert "0 % of its 2 matched layer pixels inside after optimisation (0 % before)" in lines[0]


def test_the_display_fit_doctests_hold():
    import doctest

    import vergence.specular.display_fit as module

    result = doctest.testmod(module, raise_on_error=False)
    assert result.attempted >= 4 and result.failed == 0
