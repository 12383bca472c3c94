"""``vergence match --planes``: the option reaches the library, shows in the JSON, and its misuse is one line."""

from __future__ import annotations

import json

import numpy as np

from vergence.cli import main
from vergence.depth import compute_disparity
from vergence.io import read_disparity, read_image


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main([*args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_match_planes_writes_what_the_library_computes(capsys, shared_data, tmp_path):
    tsukuba = shared_data / "stereo" / "tsukuba"
    out = tmp_path / "d.pfm"
    code, stdout, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity",
                             "15", "--planes", "--out", str(out), "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["planes"] is True and summary["known_percent"] == 100.0
    expected = compute_disparity(read_image(tsukuba / "im3.png"), read_image(tsukuba / "im4.png"), max_disparity=15,
                                 planes=True).disparity
    np.testing.assert_array_equal(read_disparity(out), expected)
    code, stdout, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity",
                             "15", "--out", str(tmp_path / "e.pfm"), "--json")
    assert code == 0 and json.loads(stdout)["planes"] is False


def test_match_planes_refuses_a_non_flag_value_in_one_line(capsys, shared_data, tmp_path):
    tsukuba = shared_data / "stereo" / "tsukuba"
    code, _, err = _run(capsys, "match", str(tsukuba / "im3.png"), str(tsukuba / "im4.png"), "--max-disparity", "15",
                        "--planes=yes", "--out", str(tmp_path / "d.pfm"))
    assert code == 2 and "--planes" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "d.pfm").exists()
