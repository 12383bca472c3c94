"""``vergence compare``'s work called as the library: the bytes ``--json`` prints, the error image, and
refusals in each face's words."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.io import read_image, write_image


@pytest.fixture
def views(tmp_path):
    """A 24 x 32 textured view, the same view with noise, a grey half mask and a colour image as a bad mask."""
    rng = np.random.default_rng(2)
    a = rng.random((24, 32, 3)).astype(np.float32)
    b = np.clip(a + rng.normal(0.0, 0.05, a.shape), 0.0, 1.0).astype(np.float32)
    mask = np.zeros((24, 32), np.float32)
    mask[:, :16] = 1.0
    write_image(tmp_path / "a.png", a)
    write_image(tmp_path / "b.png", b)
    write_image(tmp_path / "mask.png", mask)
    return tmp_path / "a.png", tmp_path / "b.png", tmp_path / "mask.png"


def _spelled_cli(exc: ParameterError) -> str:
    names = command("compare").cli_names
    return exc.spelled(lambda name: names[name])


@pytest.mark.parametrize("masked", [False, True])
def test_the_work_gives_the_bytes_the_command_prints(capsys, views, masked):
    a, b, mask = views
    extra = {"mask": mask} if masked else {}
    report = command("compare").run(image=a, reference=b, **extra)
    assert main(["compare", str(a), str(b), *(["--mask", str(mask)] if masked else []), "--json"]) == 0
    assert to_json(report.to_dict()) == capsys.readouterr().out
    assert report.to_dict()["mask"] == (str(mask) if masked else None)
    assert report.quality.pixels == (24 * 16 if masked else 24 * 32)


def test_the_error_image_is_the_gain_times_the_channel_mean_of_the_difference(views, tmp_path):
    a, b, _ = views
    out = tmp_path / "error.png"
    report = command("compare").run(image=a, reference=b, error_image=out, error_gain=2.0)
    assert report.error_image == out
    expected = np.clip(2.0 * np.abs(read_image(a) - read_image(b)).mean(axis=2), 0.0, 1.0)
    np.testing.assert_allclose(read_image(out), expected, atol=0.5 / 255 + 1e-6)  # an 8-bit PNG


def test_progress_starts_and_ends(views):
    a, b, _ = views
    heard = []
    command("compare").run(image=a, reference=b, progress=lambda f, m: heard.append((f, m)))
    assert heard == [(0.0, "comparing"), (1.0, "compared")]


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"radius": 1e6}, "radius must be a number in (0, 1024] px; got 1e+06",
     "--radius must be a number in (0, 1024] px; got 1e+06"),
    ({"error_gain": 0.0}, "error_gain must be a finite number > 0; got 0.0",
     "--error-gain must be a finite number > 0; got 0.0"),
    ({"min_contrast": -1.0}, "min_contrast must lie in [0, 0.5]; got -1",
     "--min-contrast must lie in [0, 0.5]; got -1"),
])
def test_refusals_name_the_field_and_the_option(capsys, views, options, field, cli):
    a, b, _ = views
    with pytest.raises(ParameterError) as caught:
        command("compare").run(image=a, reference=b, **options)
    assert caught.value.spelled(str) == field and _spelled_cli(caught.value) == cli
    argv = [f"--{name.replace('_', '-')}={value}" for name, value in options.items()]
    assert main(["compare", str(a), str(b), *argv]) == 2
    assert capsys.readouterr().err == f"error: {cli}\n"


def test_a_colour_mask_and_a_reference_of_another_shape_are_refused_by_name(views, tmp_path):
    a, b, _ = views
    with pytest.raises(ParameterError) as caught:
        command("compare").run(image=a, reference=b, mask=a)
    assert caught.value.spelled(str) == f"mask {a} must be a single-channel (grey) image; got shape (24, 32, 3)"
    write_image(tmp_path / "small.png", np.zeros((8, 8, 3), np.float32))
    with pytest.raises(ParameterError) as caught:
        command("compare").run(image=a, reference=tmp_path / "small.png")
    assert caught.value.spelled(str).startswith("reference must have the same shape as image (24, 32, 3)")
    assert _spelled_cli(caught.value).startswith("REFERENCE must have the same shape as image")
