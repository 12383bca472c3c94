"""Tests of vergence.report.rig_plot: the top-view frame, the frustum wedges, the files, bad input."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from numpy.testing import assert_allclose
from PIL import Image

from vergence.camera import Camera, look_at
from vergence.report.rig_plot import frustum_wedge, plot_rig, top_view_basis
from vergence.rigs import stereo_pair

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
TOL = 1e-9  # metres: the wedges are a few closed-form products, exact to rounding

# A long lens 2.2 m up, looking down -z at a subject 30 m away (the stadium's framing).
CENTER = look_at([0.0, 2.2, 0.0], [0.0, 2.2, -30.0], [0, 1, 0], fov_deg=8.0, width=480, height=270)


@dataclass(frozen=True)
class _RigCamera:  # the shape of vergence.rigs.RigCamera (interfaces §D)
    name: str
    element: str
    eye: str
    camera: Camera


def test_top_view_basis_of_a_level_camera_is_world_x_and_minus_z():
    basis = top_view_basis([CENTER])
    assert_allclose(basis, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=TOL)


def test_top_view_basis_uses_the_mean_up_of_tilted_cameras():
    # Two cameras rolled +-10 degrees about their view: the mean image-up is world +y.
    a = look_at([0, 0, 0], [0, 0, -1], [np.sin(0.17), np.cos(0.17), 0], fov_deg=40, width=64, height=48)
    b = look_at([1, 0, 0], [1, 0, -1], [-np.sin(0.17), np.cos(0.17), 0], fov_deg=40, width=64, height=48)
    basis = top_view_basis([a, b])
    assert_allclose(basis[2], [0, 1, 0], atol=TOL)
    assert_allclose(basis @ basis.T, np.eye(3), atol=TOL)
    assert np.linalg.det(basis) == pytest.approx(1.0)


def test_wedge_of_a_centred_90_degree_camera_is_symmetric():
    cam = look_at([1.0, 0.0, 2.0], [1.0, 0.0, -5.0], [0, 1, 0], fov_deg=90.0, width=100, height=50)
    wedge = frustum_wedge(cam, top_view_basis([cam]), reach=3.0)
    # Apex at (x, -z) = (1, -2); the image edges at 45 degrees, 3 m ahead: 3 m to either side.
    assert_allclose(wedge, [[1.0, -2.0], [-2.0, 1.0], [4.0, 1.0]], atol=TOL)


def test_wedge_points_along_the_viewing_direction():
    # A camera looking along world +x (to the right of the page's "along" frame of a -z camera).
    side = look_at([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0, 1, 0], fov_deg=20.0, width=64, height=48)
    wedge = frustum_wedge(side, top_view_basis([CENTER]), reach=5.0)
    middle = wedge[1:].mean(axis=0) - wedge[0]
    assert_allclose(middle / np.linalg.norm(middle), [1.0, 0.0], atol=TOL)
    assert wedge[1, 1] > wedge[2, 1]  # its left edge is on the page's upper side (towards -z)


def test_wedge_of_a_shifted_sensor_is_lopsided_and_crosses_at_convergence():
    # S0 §2: the shifted-sensor pair frames the same window at the convergence distance H.
    left, right = stereo_pair(CENTER, baseline=0.5, convergence=30.0)
    basis = top_view_basis([left, right])
    wl = frustum_wedge(left, basis, reach=30.0)
    wr = frustum_wedge(right, basis, reach=30.0)
    wc = frustum_wedge(CENTER, basis, reach=30.0)
    assert_allclose(wl[1:], wc[1:], atol=1e-6)
    assert_allclose(wr[1:], wc[1:], atol=1e-6)
    assert_allclose(wl[0], [-0.25, 0.0], atol=TOL)
    # Lopsided: the left camera's wedge leans right of its own axis.
    assert wl[2, 0] - wl[0, 0] > wl[0, 0] - wl[1, 0]


def _check_png(path):
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    with Image.open(path) as image:
        assert image.size == (1200, 600)  # FIGURE_SIZE at 100 dpi
        assert np.asarray(image.convert("L")).std() > 10  # not blank


def test_plot_rig_writes_png_and_svg_from_tuples_and_rig_cameras(tmp_path):
    left, right = stereo_pair(CENTER, baseline=0.5, convergence=30.0)
    real = [_RigCamera("subject-left", "subject", "left", left), _RigCamera("subject-right", "subject", "right", right)]
    virtual = [("center", CENTER, "center"), ("left", left, "left"), ("right", right, "right")]
    elements = [("subject", (0.0, 1.0, -30.0)), ("background", np.array([0.0, 3.0, -70.0]))]
    png = plot_rig(tmp_path / "rig.png", real, elements=elements, virtual=virtual, title="test rig")
    assert png == tmp_path / "rig.png"
    _check_png(png)
    svg = plot_rig(str(tmp_path / "rig.SVG"), [("a", CENTER, "left")])
    text = (tmp_path / "rig.SVG").read_text()
    assert svg.suffix == ".SVG" and text.lstrip().startswith("<?xml") and "<svg" in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rig.SVG", "rig.png"]  # no temporary file left


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"path": "rig.pdf"}, ValueError, r"path must end in \.png or \.svg"),
        ({"path": 3}, TypeError, "path must be"),
        ({"cameras": []}, ValueError, "cameras must hold at least one camera"),
        ({"cameras": [("a", "not a camera", "left")]}, TypeError, r"cameras\[0\] camera must be a Camera"),
        ({"cameras": [("a", CENTER)]}, TypeError, r"cameras\[0\] must be"),
        ({"cameras": CENTER}, TypeError, "cameras must be a sequence"),
        ({"cameras": [("", CENTER, "left")]}, TypeError, r"cameras\[0\] name"),
        ({"cameras": [("a", CENTER, 1)]}, TypeError, r"cameras\[0\] role"),
        ({"virtual": [("v", None, "left")]}, TypeError, r"virtual\[0\] camera"),
        ({"elements": [("s", [0, 0, np.nan])]}, ValueError, r"elements\[0\] point must be finite"),
        ({"elements": [("s", [0, 0])]}, ValueError, r"elements\[0\] point must have shape"),
        ({"elements": [[0, 0, 1]]}, TypeError, r"elements\[0\] must be a \(name, point\)"),
        ({"reach": -1.0}, ValueError, "reach must be > 0"),
        ({"title": 5}, TypeError, "title must be a str"),
    ],
)
def test_plot_rig_refuses_bad_input_and_writes_nothing(tmp_path, kwargs, error, match):
    args = {"path": "rig.png", "cameras": [("a", CENTER, "left")]} | kwargs
    path = args.pop("path")
    path = tmp_path / path if isinstance(path, str) else path
    with pytest.raises(error, match=match):
        plot_rig(path, args.pop("cameras"), **args)
    assert list(tmp_path.iterdir()) == []


def test_wedge_and_basis_refuse_bad_input():
    with pytest.raises(TypeError, match="camera must be a Camera"):
        frustum_wedge("cam", np.eye(3), reach=1.0)
    with pytest.raises(ValueError, match="reach must be > 0"):
        frustum_wedge(CENTER, np.eye(3), reach=0.0)
    with pytest.raises(ValueError, match=r"basis must have shape \(3, 3\)"):
        frustum_wedge(CENTER, np.eye(2), reach=1.0)
    with pytest.raises(TypeError, match="non-empty sequence"):
        top_view_basis([])
    upside_down = look_at([0, 0, 0], [0, 0, -1], [0, -1, 0], fov_deg=40, width=64, height=48)
    with pytest.raises(ValueError, match="cancel out"):
        top_view_basis([look_at([0, 0, 0], [0, 0, -1], [0, 1, 0], fov_deg=40, width=64, height=48), upside_down])
