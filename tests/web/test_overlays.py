"""The overlays' numbers (vergence.web.overlays) against hand-worked geometry: the specular page's divergence limit
is the vergence angle of the screen, 2 atan(e / 2D); page 2's comfort zone in px of the pair comes from the
vergence angles by hand (s = e - 2 D tan(atan(e / 2D) - theta / 2)); bad options are refused with one line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vergence.web.overlays import MAX_HEAT_SCALE_ARCMIN, specular_overlay, stereo_overlay

W, H = 160, 120
ARCMIN_TOL = 1e-9  # arcmin: the library's exact vergence formula against the same formula worked here


def _report(e: float = 0.065, d: float = 0.6, shown: float = 0.47) -> dict:
    return {"display": {"name": "samsung-2233rz", "fit": "screen", "arcmin_per_px": 1.6, "eye_separation_m": e,
                        "viewing_distance_m": d, "shown_width_m": shown, "image_width_px": W},
            "comfort_zone_arcmin": [-60.0, 60.0], "layers": [{"layer": 1, "name": "1"}, {"layer": 2, "name": "R"}]}


@pytest.mark.parametrize(("e", "d"), [(0.065, 0.6), (0.063, 3.0), (0.07, 10.0)])
def test_the_specular_divergence_limit_is_the_screens_vergence_angle(e, d):
    geo = specular_overlay(_report(e, d))
    assert geo["divergence_arcmin"] == pytest.approx(60 * math.degrees(2 * math.atan(e / (2 * d))), abs=ARCMIN_TOL)
    assert geo["zone_arcmin"] == [-60.0, 60.0]
    np.testing.assert_allclose(geo["scale"]["ticks"], np.arange(-120, 121, 30))
    assert [layer["name"] for layer in geo["layers"]] == ["1", "R"]


def test_page_2s_zone_and_limit_in_px_of_the_pair():
    from vergence.viewing import Display

    display = Display.preset("desktop-24")
    geo = stereo_overlay({"source": "depth", "display": {"preset": "desktop-24"}, "size": [W, H]})
    e, dist, pitch = display.eye_separation, display.distance, display.width / display.resolution
    per_px = display.resolution / W
    for theta, px in zip((-60, 60), geo["zone_px"]):
        metres = e - 2 * dist * math.tan(math.atan(e / (2 * dist)) - math.radians(theta / 60) / 2)
        assert px == pytest.approx(metres / pitch / per_px, rel=1e-9)
    assert geo["divergence_px"] == pytest.approx(e / display.width * W, rel=1e-12)
    assert geo["parallax"] == "parallax.npy" and geo["views"] == ["left.png", "right.png"]


def test_the_input_overlay_needs_a_stereo_pair():
    summary = {"source": "depth", "display": {"preset": "desktop-24"}, "size": [W, H]}
    with pytest.raises(ValueError, match="of=input needs a job of a stereo pair"):
        stereo_overlay(summary, of="input")
    with pytest.raises(ValueError, match="of must be one of result, input; got 'matched'"):
        stereo_overlay(summary, of="matched")
    pair = stereo_overlay({**summary, "source": "pair"}, of="input")
    assert pair["parallax"] == "matched_parallax.npy" and pair["views"] == ["input_left.png", "input_right.png"]


@pytest.mark.parametrize("scale", [0.0, -1.0, float("nan"), MAX_HEAT_SCALE_ARCMIN * 1.01])
def test_a_bad_colour_scale_is_refused(scale):
    with pytest.raises(ValueError, match="scale_arcmin must be > 0 and at most 600"):
        specular_overlay(_report(), scale_arcmin=scale)
    with pytest.raises(ValueError, match="scale_arcmin must be > 0 and at most 600"):
        stereo_overlay({"source": "depth", "display": {"preset": "desktop-24"}, "size": [W, H]}, scale_arcmin=scale)
