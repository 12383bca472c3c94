"""Issue 9 sweep kin in vergence.report.preview: wrong values refused in one line naming the argument.

Before: a string depth gave numpy's "could not convert string to float", a depth of 1e308 a matplotlib
overflow warning, a number as folder or stem a TypeError from pathlib or a file named "1.5.npz".
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from vergence.report.preview import depth_preview, save_render


@pytest.mark.parametrize(
    ("depth", "kwargs", "error", "message"),
    [
        ("abc", {}, TypeError, "depth must be a real-valued array; got str"),
        (np.full((4, 5), 1e308), {}, ValueError, "depth must lie within 1e+20 m (MAX_SCENE_DEPTH); got |depth| up to 1e+308"),
        (np.array([[1.0, -1e21]]), {}, ValueError, "depth must lie within 1e+20 m (MAX_SCENE_DEPTH); got |depth| up to 1e+21"),
        (np.ones((4, 5)), {"title": None}, TypeError, "title must be a str; got NoneType"),
    ],
)
def test_depth_preview_refuses(depth, kwargs, error, message):
    with pytest.raises(error, match=f"^{re.escape(message)}$"):
        depth_preview(depth, **kwargs)


def test_depth_preview_draws_its_limits_and_no_hits():
    for depth in (np.array([[-1e20, 1e20]]), np.array([[1.0, np.nan], [np.inf, 2.0]]), np.full((3, 3), np.nan)):
        img = depth_preview(depth)
        assert img.ndim == 3 and np.isfinite(img).all()


@pytest.fixture(scope="module")
def result():
    from vergence.render import builtin_scene, render

    return render(builtin_scene("tabletop", width=4, height=3), samples=1, max_depth=0)


@pytest.mark.parametrize(
    ("folder", "stem", "error", "message"),
    [
        (1.5, "render", TypeError, "folder must be a str or os.PathLike; got float"),
        ("FILE", "render", NotADirectoryError, "folder must be a folder; "),
        ("DIR", 1.5, TypeError, "stem must be a str; got float"),
        ("DIR", "", ValueError, "stem must be a plain file-name stem (no folder); got ''"),
        ("DIR", "sub/render", ValueError, "stem must be a plain file-name stem (no folder); got 'sub/render'"),
    ],
)
def test_save_render_refuses_before_writing(tmp_path, result, folder, stem, error, message):
    (tmp_path / "file.txt").write_text("x")
    folder = {"FILE": tmp_path / "file.txt", "DIR": tmp_path}.get(folder, folder)
    with pytest.raises(error, match=f"^{re.escape(message)}"):
        save_render(result, folder, stem=stem)
    assert [p.name for p in tmp_path.iterdir()] == ["file.txt"]
