"""The demo writes a self-consistent report whose numbers follow S0's equations."""

from __future__ import annotations

import re

import pytest

import vergence.report.demo as demo_module
from vergence.cli import main
from vergence.report.demo import DEMO_DISPLAY, SUBJECT_DEPTH
from vergence.report.html import Figure, Section, render_report, write_report


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The whole demo, run once for the module through ``vergence demo --out``; its DemoResult."""
    seen = []
    run = demo_module.run_demo

    def recording(*args, **kwargs):
        seen.append(run(*args, **kwargs))
        return seen[-1]

    out = tmp_path_factory.mktemp("demo") / "d"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(demo_module, "run_demo", recording)
        assert main(["demo", "--out", str(out)]) == 0
    assert len(seen) == 1 and seen[0].index == out / "index.html"
    return seen[0]


def test_demo_writes_index_with_existing_figures(demo):
    result = demo
    html = result.index.read_text(encoding="utf-8")
    figures = re.findall(r'<img src="([^"]+)"', html)
    assert len(figures) >= 15
    for name in figures:
        assert (result.index.parent / name).stat().st_size > 1_000  # a real image, not an empty file
    # S0 Eq. (6): b_round / b_div = f/f' = 10 / 2.5 = 4.
    assert result.divergence_rig.focal_ratio == pytest.approx(4.0)
    # With b_div the subject is cardboard: rho(H) = b H'/(H b') = 0.1625 * 3 / (30 * 0.065) = 0.25.
    subject = next(s for s in result.divergence_rig.samples if s.depth == SUBJECT_DEPTH)
    assert subject.roundness == pytest.approx(0.25)
    # With b_round the eyes diverge beyond bHW'/(bW' - b'W) = 0.65*30*1.2/(0.78 - 0.195) = 40 m.
    assert result.roundness_rig.divergence_depth == pytest.approx(40.0)
    # The Tri-Rig mapping meets its constraints and never asks the eyes to diverge.
    assert result.tri_rig.monotone and not result.tri_rig.diverges
    assert float(result.tri_rig.perceived_depth(SUBJECT_DEPTH)) == pytest.approx(DEMO_DISPLAY.distance)
    assert float(result.tri_rig.roundness(SUBJECT_DEPTH)) == pytest.approx(1.0)
    # ... and, unlike either plain rig, leaves the bleachers (80 m) neither diverging nor cardboard.
    assert 3.0 < float(result.tri_rig.perceived_depth(80.0)) < float("inf")
    assert float(result.tri_rig.roundness(80.0)) > 0.3
    # Measured on the rendered stadium: b_round pushes the bleachers past the divergence limit, b_div does not.
    limit_px = DEMO_DISPLAY.divergence_disparity * DEMO_DISPLAY.resolution
    assert result.stadium_disparity_px["b_round"][1] > limit_px > result.stadium_disparity_px["b_div"][1] > 0
    assert result.stadium_disparity_px["b_div"][0] < 0  # the ball and the player's feet are in front of the screen
    # DIBR right eye against the ray-traced one (measured 32.4 dB / SSIM 0.979 at 640x480): a broken warp
    # (wrong sign, wrong scale, foreground smeared into holes) falls far below these bounds.
    assert result.dibr_quality.psnr_db > 30.0
    assert result.dibr_quality.ssim > 0.95


def test_demo_cli_and_bad_output(demo, tmp_path, capsys):
    assert demo.index.is_file()
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["demo", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err
    assert "out must be a folder" in err and "Traceback" not in err


def test_report_escapes_text_and_checks_figures(tmp_path):
    html = render_report(title="a < b", intro="x & y", sections=[Section("t", "<script>", table=(("h",), ("1",)))])
    assert "a &lt; b" in html and "&lt;script&gt;" in html and "<script>" not in html
    with pytest.raises(ValueError, match="missing.png does not exist"):
        write_report(tmp_path / "i.html", title="t", intro="i", sections=[Section("s", "p", (Figure("missing.png", "c"),))])
