"""Tests of ``vergence budget``: JSON against independent hand computations, the table, the plot, errors."""

from __future__ import annotations

import json

import pytest

from vergence.cli import main

# Hand computations below use the same formulas with other roundings: a few ulps.
RTOL = 1e-12
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["budget", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# A rig of our own: b = 0.12 m, H = 8 m, W = 2.4 m (f = 10/3) on a 1.1 m, 1280 px screen at 2.2 m
# (f' = 2) with eyes 63 mm apart. b_div = 0.063 * 2.4 / 1.1 = 0.13745 m > b: no divergence.
RIG_ARGS = ["--baseline", "0.12", "--convergence", "8", "--window", "2.4"]
DISPLAY_ARGS = ["--eye-separation", "0.063", "--viewing-distance", "2.2", "--screen-width", "1.1"]


def _hand(z: float, b=0.12, H=8.0, W=2.4, bp=0.063, Hp=2.2, Wp=1.1, N=1280) -> dict[str, float]:
    d = b / W * (z - H) / z  # S0 Eq. (1a)
    den = z * (bp * W - b * Wp) + b * H * Wp
    return {"depth": z, "disparity": d, "parallax_px": d * N, "perceived_depth": z * bp * Hp * W / den,
            "roundness": b * Hp * W / den}


def test_divergence_depth_is_where_the_disparity_reaches_the_eyes_limit(capsys):
    # b = 0.2 > b_div: d(z) = b/W (z - H)/z reaches b'/W' at z = H / (1 - (b'/W')(W/b)) (S0 Eq. 1a, 2).
    code, out, _err = _run(capsys, "--baseline", "0.2", "--convergence", "8", "--window", "2.4", *DISPLAY_ARGS,
                           "--depth", "8", "--json")
    assert code == 0
    want = 8 / (1 - (0.063 / 1.1) * (2.4 / 0.2))
    assert json.loads(out)["divergence_depth"] == pytest.approx(want, rel=RTOL)


def test_json_matches_hand_computation(capsys):
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--screen-pixels", "1280",
                          "--depth", "4", "--depth", "8", "--depth", "20", "--depth", "100", "--json")
    # The +-60 arcmin zone at 2.2 m is +-2.2 tan(1 deg)/1.1 = +-0.0349 of the width: d(4) = -0.05 and
    # d(100) = +0.046 lie outside (issue 9: leaving the comfort zone is a warning, on stderr and in the JSON).
    zone = "outside the comfort zone (±60 arcmin of vergence: d from -0.03492 to +0.03491 of the screen width)"
    assert code == 0 and err == f"warning: {zone}: z = 4, 100 m\n"
    data = json.loads(out)
    assert list(data) == ["divergence_baseline", "roundness_baseline", "focal_ratio", "divergence_depth", "depths",
                          "warnings"]
    assert data["divergence_depth"] is None  # b < b_div: the eyes never diverge
    assert data["warnings"] == [f"{zone}: z = 4, 100 m"]
    assert data["divergence_baseline"] == pytest.approx(0.063 * 2.4 / 1.1, rel=RTOL)
    assert data["roundness_baseline"] == pytest.approx(0.063 * 8 / 2.2, rel=RTOL)
    assert data["focal_ratio"] == pytest.approx((8 / 2.4) / (2.2 / 1.1), rel=RTOL)
    assert [row["depth"] for row in data["depths"]] == [4.0, 8.0, 20.0, 100.0]
    for row in data["depths"]:
        want = _hand(row["depth"])
        assert list(row) == ["depth", "disparity", "parallax_px", "perceived_depth", "roundness", "diverges"]
        for key, value in want.items():
            assert row[key] == pytest.approx(value, rel=RTOL, abs=1e-15), key
        assert row["diverges"] is False
    # On the convergence plane: zero disparity, perceived on the screen.
    assert data["depths"][1]["disparity"] == 0.0
    assert data["depths"][1]["perceived_depth"] == pytest.approx(2.2, rel=RTOL)


def test_json_with_divergence_and_focal_length(capsys):
    # F = 50 mm on a 36 mm sensor: f = 50/36, W = 20 * 36/50 = 14.4 m. Baseline 1 m > b_div =
    # 0.065 * 14.4 / 1.2 = 0.78 m: divergence beyond bHW'/(bW' - b'W) = 24/(1.2 - 0.936) = 90.9 m.
    code, out, _ = _run(capsys, "--baseline", "1", "--convergence", "20", "--focal-mm", "50", "--sensor-mm", "36",
                        "--eye-separation", "0.065", "--viewing-distance", "3", "--screen-width", "1.2",
                        "--depth", "50", "--depth", "200", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["divergence_baseline"] == pytest.approx(0.065 * 14.4 / 1.2, rel=RTOL)
    assert data["focal_ratio"] == pytest.approx((50 / 36) / 2.5, rel=RTOL)
    near, far = data["depths"]
    assert "parallax_px" not in near  # no screen resolution given
    want = _hand(50.0, b=1.0, H=20.0, W=14.4, bp=0.065, Hp=3.0, Wp=1.2)
    assert near["perceived_depth"] == pytest.approx(want["perceived_depth"], rel=RTOL)
    assert near["roundness"] == pytest.approx(want["roundness"], rel=RTOL) and near["diverges"] is False
    assert far["perceived_depth"] is None and far["diverges"] is True
    den = 200 * (0.065 * 14.4 - 1.0 * 1.2) + 1.0 * 20 * 1.2
    assert far["roundness"] == pytest.approx(1.0 * 3.0 * 14.4 / den, rel=RTOL) and far["roundness"] < 0


def test_display_preset_gives_pixels(capsys):
    code, out, _ = _run(capsys, *RIG_ARGS, "--display", "samsung-2233rz", "--depth", "16", "--json")
    assert code == 0
    row = json.loads(out)["depths"][0]
    d = 0.12 / 2.4 * (16 - 8) / 16
    assert row["disparity"] == pytest.approx(d, rel=RTOL)
    assert row["parallax_px"] == pytest.approx(d * 1680, rel=RTOL)
    # --screen-pixels overrides the preset's resolution.
    _, out, _ = _run(capsys, *RIG_ARGS, "--display", "samsung-2233rz", "--screen-pixels", "840", "--depth", "16",
                     "--json")
    assert json.loads(out)["depths"][0]["parallax_px"] == pytest.approx(d * 840, rel=RTOL)


def test_default_depths(capsys):
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--json")
    assert code == 0
    assert [row["depth"] for row in json.loads(out)["depths"]] == [4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 40.0, 80.0]


def test_table_output(capsys):
    code, out, err = _run(capsys, "--baseline", "0.65", "--convergence", "30", "--window", "3",
                          "--eye-separation", "0.065", "--viewing-distance", "3", "--screen-width", "1.2",
                          "--depth", "30", "--depth", "60")
    assert code == 0
    assert err == ("warning: the eyes diverge at z = 60 m (beyond z = 40 m): baseline b = 0.65 m exceeds "
                   "b_div = 0.1625 m (S0 Eq. 3)\n")
    assert "divergence baseline b_div = 0.1625 m" in out
    assert "roundness baseline b_round = 0.65 m" in out
    assert "focal ratio f/f' = 4" in out
    assert "eyes diverge beyond z = 40 m" in out  # 0.65*30*1.2 / (0.78 - 0.195)
    assert "eyes" in out.split("depth budget", 1)[1]  # the 60 m row is flagged


def test_plot_with_json_keeps_stdout_pure(capsys, tmp_path):
    target = tmp_path / "budget.png"
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--depth", "4", "--depth", "40", "--json",
                          "--plot", str(target))
    assert code == 0
    json.loads(out)  # nothing but JSON on stdout
    assert "plot written" in err
    assert target.read_bytes()[:8] == PNG_SIGNATURE
    assert [p.name for p in tmp_path.iterdir()] == ["budget.png"]  # no temporary file left behind


def test_plot_with_a_single_depth(capsys, tmp_path):
    target = tmp_path / "one.png"
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--depth", "8", "--plot", str(target))
    assert code == 0 and "plot written" in out
    assert target.read_bytes()[:8] == PNG_SIGNATURE


@pytest.mark.parametrize("args, message", [
    (["--baseline", "-0.1", "--convergence", "8", "--window", "2.4", *DISPLAY_ARGS],
     "error: --baseline must be > 0; got -0.1"),
    (["--baseline", "nan", "--convergence", "8", "--window", "2.4", *DISPLAY_ARGS],
     "error: --baseline must be finite; got nan"),
    ([*RIG_ARGS, "--eye-separation", "0", "--viewing-distance", "2.2", "--screen-width", "1.1"],
     "error: --eye-separation must be > 0; got 0"),
    ([*RIG_ARGS, *DISPLAY_ARGS, "--depth", "-5"],
     "error: --depth must be > 0 (in front of the cameras); got -5"),
    ([*RIG_ARGS, *DISPLAY_ARGS, "--depth", "nan"], "error: --depth must be > 0 metres or inf (a point at infinity); got nan"),
    ([*RIG_ARGS, "--display", "imax"], "error: --display: unknown display preset 'imax'; valid presets: cinema, desktop-24,"),
    (["--baseline", "0.1", "--convergence", "8", "--focal-mm", "50", *DISPLAY_ARGS],
     "error: --sensor-mm (sensor width in mm) is required with --focal-mm"),
    (["--baseline", "0.1", "--convergence", "8", "--sensor-mm", "36", *DISPLAY_ARGS],
     "error: --focal-mm (focal length in mm) is required with --sensor-mm"),
    ([*RIG_ARGS, "--focal-mm", "50", "--sensor-mm", "36", *DISPLAY_ARGS],
     "error: give either --window or --focal-mm with --sensor-mm, not both"),
    (["--baseline", "0.1", "--convergence", "8", *DISPLAY_ARGS],
     "error: the convergence window is missing: give --window, or --focal-mm with --sensor-mm"),
    ([*RIG_ARGS, *DISPLAY_ARGS, "--display", "tv-55"],
     "error: give either --display or the display lengths, not both (got --display and --eye-separation,"),
    (RIG_ARGS, "error: the display is incomplete: give --display PRESET or all three lengths (missing "
               "--eye-separation, --viewing-distance, --screen-width)"),
    ([*RIG_ARGS, "--eye-separation", "0.063", "--screen-width", "1.1"],
     "error: the display is incomplete: give --display PRESET or all three lengths (missing --viewing-distance)"),
    ([*RIG_ARGS, *DISPLAY_ARGS, "--screen-pixels", "0"],
     "error: --screen-pixels must be >= 1 (the screen width in pixels); got 0"),
    ([*RIG_ARGS, "--display", "phone", "--screen-pixels", "-3"],
     "error: --screen-pixels must be >= 1 (the screen width in pixels); got -3"),
    ([*RIG_ARGS, *DISPLAY_ARGS, "--depth", "1e21"], "error: --depth must lie in [1e-06, 1e+20] m; got 1e+21"),
    (["--baseline", "0.1", "--convergence", "inf", "--window", "2.4", *DISPLAY_ARGS],
     "error: --convergence must be finite; got inf"),
    (["--baseline", "0.1", "--convergence", "8", "--focal-mm", "0", "--sensor-mm", "36", *DISPLAY_ARGS],
     "error: --focal-mm must be > 0; got 0"),
    (["--baseline", "0.1", "--convergence", "8", "--focal-mm", "50", "--sensor-mm", "-36", *DISPLAY_ARGS],
     "error: --sensor-mm must be > 0; got -36"),
    # issue 9: ZeroDivisionError before, then Python's names; overflow warnings at 1e308
    (["--baseline", "0.1", "--convergence", "8", "--focal-mm", "5e-324", "--sensor-mm", "36", *DISPLAY_ARGS],
     "error: --focal-mm must lie in [0.001, 1e+09] mm; got 4.94066e-324"),
    (["--baseline", "1e308", "--convergence", "8", "--window", "2.4", *DISPLAY_ARGS],
     "error: --baseline must lie in [1e-06, 1e+06] m; got 1e+308"),
    ([*RIG_ARGS, "--eye-separation", "0.063", "--viewing-distance", "-3", "--screen-width", "1.1"],
     "error: --viewing-distance must be > 0; got -3"),
    ([*RIG_ARGS, "--eye-separation", "0.063", "--viewing-distance", "2", "--screen-width", "inf"],
     "error: --screen-width must be finite; got inf"),
    (["--baseline", "0.1", "--convergence", "8", "--focal-mm", "0.001", "--sensor-mm", "1e9", *DISPLAY_ARGS],
     "error: the convergence window H S/F from --convergence, --sensor-mm and --focal-mm must lie in [1e-06, 1e+06] m; got 8e+12"),
])
def test_bad_input_is_one_line_and_exit_code_2(capsys, args, message):
    code, out, err = _run(capsys, *args, "--json")
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith(message)


def test_bad_plot_path(capsys, tmp_path):
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--plot", str(tmp_path / "budget.jpg"))
    assert code == 2 and err.startswith("error: --plot must end in .png; got ") and err.count("\n") == 1
    code, _, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--plot", str(tmp_path / "missing" / "budget.png"))
    assert code == 2 and "does not exist" in err and err.count("\n") == 1


def test_help_lists_the_options(capsys):
    assert main(["budget", "--help"]) == 0
    text = capsys.readouterr().out
    for option in ("--baseline", "--convergence", "--window", "--eye-separation", "--viewing-distance",
                   "--screen-width", "--screen-pixels", "--depth", "--focal-mm", "--sensor-mm", "--display",
                   "--json", "--plot"):
        assert option in text


def test_depth_inf_is_accepted_like_mapping(capsys):
    # Issue 9: `budget --depth inf` was refused while `mapping` takes it. At infinity d = b/W = 0.05,
    # z' = b'H'W/(b'W - bW') = 0.063*2.2*2.4/(0.063*2.4 - 0.12*1.1) = 17.42 m (S0 Eq. 2), rho -> 0.
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--depth", "8", "--depth", "inf", "--json")
    assert code == 0
    far = json.loads(out)["depths"][1]
    assert far["depth"] is None  # JSON has no infinity: null
    assert far["disparity"] == pytest.approx(0.05, rel=RTOL)
    assert far["perceived_depth"] == pytest.approx(0.063 * 2.2 * 2.4 / (0.063 * 2.4 - 0.12 * 1.1), rel=1e-12)
    assert far["roundness"] == 0.0 and far["diverges"] is False
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--depth", "inf")
    assert code == 0 and "∞" in out


def test_table_rows_match_the_json_and_name_parallel_eyes(capsys):
    # Issue 9 (demo page): the table hid the roundness past divergence ("—") while the JSON gave -0.25,
    # and printed nothing for parallel eyes. Dyadic set-up: b = 1, H = 4, W = 1 on b' = 0.5, H' = 2, W' = 1:
    # d(8) = 0.5 = b'/W' exactly (parallel eyes); d(16) = 0.75 > 0.5 diverges, rho = bH'W/(z(b'W - bW') + bHW')
    # = 2/(16*(-0.5) + 4) = -0.5 (S0 Eq. 4).
    args = ["--baseline", "1", "--convergence", "4", "--window", "1", "--eye-separation", "0.5",
            "--viewing-distance", "2", "--screen-width", "1", "--depth", "8", "--depth", "16"]
    code, out, _ = _run(capsys, *args)
    assert code == 0
    rows = [line for line in out.splitlines() if line.startswith("│")]
    assert [cell.strip() for cell in rows[0].split("│")[1:-1]] == ["8", "+50.000", "∞", "—", "eyes parallel"]
    assert [cell.strip() for cell in rows[1].split("│")[1:-1]] == ["16", "+75.000", "—", "-0.500", "eyes diverge"]
    code, out, _ = _run(capsys, *args, "--json")
    parallel, diverging = json.loads(out)["depths"]
    assert parallel["roundness"] is None and diverging["roundness"] == -0.5
