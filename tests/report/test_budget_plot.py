"""Tests of vergence.report.budget_plot: a valid PNG, the markings, no pyplot state, bad input."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pytest
from PIL import Image

from vergence.report.budget_plot import plot_budget
from vergence.viewing.geometry import Display, Shooting

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
TV = Display(eye_separation=0.065, distance=3.0, width=1.2)  # f' = 2.5
ROUND = Shooting(baseline=0.65, convergence=30.0, window=3.0)  # b_round: diverges beyond 40 m
DIVERGENCE_FREE = Shooting(baseline=0.1625, convergence=30.0, window=3.0)  # b_div: roundness 0.25
# Pure colours of the divergence line (tab:red) and the cardboard line (tab:orange): line cores
# are drawn unblended, so exact matches count them.
TAB_RED = (214, 39, 40)
TAB_ORANGE = (255, 127, 14)


def _pixels_of(path, rgb) -> int:
    image = np.asarray(Image.open(path).convert("RGB"))
    return int(np.all(image == np.array(rgb, dtype=np.uint8), axis=-1).sum())


def test_writes_a_valid_png_atomically(tmp_path):
    target = tmp_path / "budget.png"
    assert plot_budget(ROUND, TV, near=10.0, far=100.0, path=target) == target
    assert target.read_bytes()[:8] == PNG_SIGNATURE
    with Image.open(target) as image:
        image.verify()
    with Image.open(target) as image:
        assert image.format == "PNG" and image.size == (825, 770)  # 7.5 x 7 inches at 110 dpi
        assert np.asarray(image.convert("L")).std() > 10  # not a blank canvas
    assert [p.name for p in tmp_path.iterdir()] == ["budget.png"]  # no temporary file left
    # An existing file is replaced.
    plot_budget(DIVERGENCE_FREE, TV, near=10.0, far=100.0, path=str(target))
    assert target.read_bytes()[:8] == PNG_SIGNATURE


def test_divergence_limit_is_marked_only_when_the_rig_diverges(tmp_path):
    plot_budget(ROUND, TV, near=10.0, far=100.0, path=tmp_path / "round.png")
    plot_budget(DIVERGENCE_FREE, TV, near=10.0, far=100.0, path=tmp_path / "free.png")
    assert _pixels_of(tmp_path / "round.png", TAB_RED) > 200
    assert _pixels_of(tmp_path / "free.png", TAB_RED) == 0
    # The cardboard threshold rho = 0.3 is drawn in both.
    assert _pixels_of(tmp_path / "round.png", TAB_ORANGE) > 200
    assert _pixels_of(tmp_path / "free.png", TAB_ORANGE) > 200


def test_no_pyplot_figures_are_left_open(tmp_path):
    before = plt.get_fignums()
    plot_budget(ROUND, TV, near=0.5, far=500.0, path=tmp_path / "wide.png")  # log axis branch
    assert plt.get_fignums() == before


@pytest.mark.parametrize("kw, error, match", [
    (dict(near=0.0), ValueError, "^near must be > 0; got 0"),
    (dict(near=-1.0), ValueError, "^near must be > 0; got -1"),
    (dict(far=math.nan), ValueError, "^far must be finite; got nan"),
    (dict(near=50.0, far=50.0), ValueError, "^far must be > near; got near=50, far=50"),
    (dict(path="budget.svg"), ValueError, "^path must end in .png; got 'budget.svg'"),
])
def test_bad_input(tmp_path, kw, error, match):
    args = dict(near=10.0, far=100.0, path=tmp_path / "b.png")
    args.update(kw)
    with pytest.raises(error, match=match):
        plot_budget(ROUND, TV, **args)
    assert not (tmp_path / "b.png").exists()


def test_bad_set_ups_and_missing_folder(tmp_path):
    with pytest.raises(TypeError, match="^shooting must be a Shooting; got NoneType"):
        plot_budget(None, TV, near=1.0, far=2.0, path=tmp_path / "b.png")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="^display must be a vergence.viewing.Display; got str"):
        plot_budget(ROUND, "tv-55", near=1.0, far=2.0, path=tmp_path / "b.png")  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="does not exist"):
        plot_budget(ROUND, TV, near=1.0, far=2.0, path=tmp_path / "nope" / "b.png")
