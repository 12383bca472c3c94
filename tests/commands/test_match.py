"""``vergence match``'s work called as the library: the bytes ``--json`` prints, the hooks, all outputs
or none, and refusals in each face's words."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vergence.cli import main
from vergence.commands import ParameterError, command, to_json
from vergence.io import read_disparity, write_image

SHIFT = 6  # px: the right view is the left one moved left by SHIFT (x_left - x_right = SHIFT)


@pytest.fixture
def pair(tmp_path):
    """A textured 80 x 120 grey pair whose true disparity is SHIFT everywhere, a half mask, a colour image."""
    rng = np.random.default_rng(5)
    texture = np.repeat(np.repeat(rng.random((20, 32)), 4, axis=0), 4, axis=1).astype(np.float32)  # 80 x 128
    write_image(tmp_path / "left.png", texture[:, :120])
    write_image(tmp_path / "right.png", texture[:, SHIFT:120 + SHIFT])
    valid = np.ones((80, 120), np.float32)
    valid[:, :30] = 0.0
    write_image(tmp_path / "valid.png", valid)
    write_image(tmp_path / "colour.png", np.dstack([texture[:, :120]] * 3))
    return tmp_path / "left.png", tmp_path / "right.png", tmp_path / "valid.png", tmp_path / "colour.png"


def _cli(exc: ParameterError) -> str:
    names = command("match").cli_names
    return exc.spelled(lambda name: names[name])


@pytest.mark.parametrize("masked", [False, True])
def test_the_work_gives_the_bytes_the_command_prints(capsys, pair, tmp_path, masked):
    left, right, valid, _ = pair
    out = tmp_path / "d.pfm"
    extra = {"mask": valid} if masked else {}
    report = command("match").run(left=left, right=right, max_disparity=16, out=out, **extra)
    from_work = read_disparity(out)
    assert main(["match", str(left), str(right), "--max-disparity", "16", "--out", str(out),
                 *(["--mask", str(valid)] if masked else []), "--json"]) == 0
    printed = capsys.readouterr().out
    # the same summary but the time it took, which two runs never share
    data = report.to_dict()
    data["seconds"] = json.loads(printed)["seconds"]
    assert to_json(data) == printed
    np.testing.assert_array_equal(read_disparity(out), from_work)
    assert report.to_dict()["mask"] == (str(valid) if masked else None) and report.to_dict()["out"] == str(out)
    # the pair's disparity is SHIFT; the masked-out columns are unknown
    known = from_work[:, 40:100]
    assert np.median(known) == pytest.approx(SHIFT, abs=0.5)
    assert np.isnan(from_work[:, :30]).all() == masked


def test_hooks_hear_the_stages_the_warnings_and_the_commit(pair, tmp_path):
    left, _, _, _ = pair  # the left view twice: disparity 0, which a PNG stores as 1/scale, with a warning
    heard = []
    report = command("match").run(left=left, right=left, max_disparity=16, out=tmp_path / "d.png", scale=16.0,
                                  progress=lambda f, m: heard.append(("progress", f, m)),
                                  warn=lambda line: heard.append(("warn", line)),
                                  before_commit=lambda: heard.append(("commit", (tmp_path / "d.png").exists())))
    assert heard[0] == ("progress", 0.0, "matching (sgbm)") and heard[1] == ("progress", 1.0, "matched (sgbm)")
    assert report.warnings and "are stored as 1/16 px" in report.warnings[-1]
    assert heard[2:-1] == [("warn", w) for w in report.warnings]
    assert heard[-1] == ("commit", False)  # before the output appears
    assert (tmp_path / "d.png").exists()


def test_an_interrupted_commit_writes_nothing(pair, tmp_path):
    left, right, _, _ = pair
    before = sorted(p.name for p in tmp_path.iterdir())

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        command("match").run(left=left, right=right, max_disparity=16, out=tmp_path / "d.pfm",
                             preview=tmp_path / "p.png", confidence=tmp_path / "c.png", before_commit=interrupted)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize(("options", "field", "cli"), [
    ({"block_size": 4}, "block_size must be an odd number of pixels in [1, 255]; got 4",
     "--block-size must be an odd number of pixels in [1, 255]; got 4"),
    ({"pm_step": 2, "pm_alpha": 0.5}, "pm_step, pm_alpha: for method patchmatch only; got method sgbm",
     "--pm-step, --pm-alpha: for --method patchmatch only; got --method sgbm"),
    ({"method": "patchmatch", "pm_step": 0}, "pm_step must be >= 1; got 0", "--pm-step must be >= 1; got 0"),
    ({"out_name": "d.png"}, "out d.png stores integers: give scale (stored value = disparity x scale; 0 = unknown)",
     "--out d.png stores integers: give --scale (stored value = disparity x scale; 0 = unknown)"),
    ({"out_name": "d.png", "scale": 5000.0},
     "max_disparity 16 x scale 5000 exceeds 65535, the largest 16-bit value of d.png: lower scale, or write .pfm "
     "or .npy",
     "--max-disparity 16 x --scale 5000 exceeds 65535, the largest 16-bit value of d.png: lower --scale, or write "
     ".pfm or .npy"),
    ({"preview_name": "d.pfm"}, "out, preview and confidence must name different files",
     "--out, --preview and --confidence must name different files"),
    ({"right": "colour.png"}, "left and right must both be grey or both colour; got grey and colour",
     "LEFT and RIGHT must both be grey or both colour; got grey and colour"),
    ({"mask": "colour.png"}, "mask colour.png must be a grey image; got 3 channels",
     "--mask colour.png must be a grey image; got 3 channels"),
    ({"smoothing": "wls"}, "smoothing must be one of median, none; got 'wls'",
     "--smoothing must be one of median, none; got 'wls'"),
])
def test_refusals_name_the_field_and_the_option(capsys, pair, tmp_path, options, field, cli):
    left, right, _, _ = pair
    values = {"left": left, "right": right, "max_disparity": 16, "out": tmp_path / options.pop("out_name", "d.pfm")}
    if "preview_name" in options:
        values["preview"] = tmp_path / options.pop("preview_name")
    values.update({k: tmp_path / v if k in ("right", "mask") else v for k, v in options.items()})
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(ParameterError) as caught:
        command("match").run(**values)
    assert caught.value.spelled(str) == field and _cli(caught.value) == cli
    argv = [str(values.pop("left")), str(values.pop("right"))]
    for name, value in values.items():
        argv.append(f"--{name.replace('_', '-')}={value}")
    assert main(["match", *argv]) == 2
    assert capsys.readouterr().err == f"error: {cli}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == before
