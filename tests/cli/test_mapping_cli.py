"""Tests of ``vergence mapping``: JSON against an independent computation, the summary, the plot, errors."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from vergence.cli import main

# Hand computations below use the same formulas with other roundings: a few ulps.
RTOL = 1e-12
# psi' by central differences of our own psi (step 1e-7 in d of order 0.1): error ~1e-7 relative.
FD_STEP = 1e-7
FD_RTOL = 1e-5
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# A rig of our own: reference b_r = 0.5 m, H = 20 m, W = 2.5 m (f = 8) on a 1.1 m screen at 2.2 m
# (f' = 2), eyes 63 mm apart. d(z) = 0.2 (1 - 20/z): d(10) = -0.2, d(inf) = +0.2, so the middle
# of the 201 JSON samples is the subject at z = H.
B, H, W = 0.5, 20.0, 2.5
BP, HP, WP = 0.063, 2.2, 1.1
RIG_ARGS = ["--reference-baseline", str(B), "--convergence", str(H), "--window", str(W)]
DISPLAY_ARGS = ["--eye-separation", str(BP), "--viewing-distance", str(HP), "--screen-width", str(WP)]


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["mapping", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _psi(d: np.ndarray, cps: list[dict]) -> np.ndarray:
    """Our own psi from the control points: slope-continued line below, Gregory–Delbourgo between
    (S0 §6, the plain formula), saturating towards b'/W' above (the documented extension)."""
    x = np.array([c["disparity"] for c in cps])
    y = np.array([c["value"] for c in cps])
    s = np.array([c["slope"] for c in cps])
    out = np.empty_like(d)
    for k, v in enumerate(d):
        if v <= x[0]:
            out[k] = y[0] + s[0] * (v - x[0])
        elif v >= x[-1]:
            gap = BP / WP - y[-1]
            out[k] = y[-1] if gap == 0 else BP / WP - gap * math.exp(-s[-1] * (v - x[-1]) / gap)
        else:
            i = np.searchsorted(x, v) - 1
            h = x[i + 1] - x[i]
            t = (v - x[i]) / h
            delta = (y[i + 1] - y[i]) / h
            out[k] = y[i] + (y[i + 1] - y[i]) * (delta * t**2 + s[i] * t * (1 - t)) / (
                delta + (s[i + 1] + s[i] - 2 * delta) * t * (1 - t)
            )
    return out


def test_json_schema_and_values_match_independent_computation(capsys):
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2,roundness=1",
                          "--constraint", "z=50,perceived=4", "--near", "10", "--far", "inf", "--json")
    # psi(d(10)) = psi(-0.2) = -0.2291: 23 % of the screen width crossed, far outside +-60 arcmin at 2.2 m
    # (+-2.2 tan(1 deg)/1.1 = +-0.0349): a warning on stderr and in the JSON (issue 9).
    warning = ("mapped disparities from -0.2291 to +0.03902 screen widths leave the comfort zone "
               "(±60 arcmin of vergence: -0.03492 to +0.03491)")
    assert code == 0 and err == f"warning: {warning}\n"
    data = json.loads(out)
    assert list(data) == ["reference", "display", "near", "far", "control_points", "samples", "monotone",
                          "diverges", "warnings"]
    assert data["reference"] == {"baseline": B, "convergence": H, "window": W}
    assert data["display"] == {"eye_separation": BP, "distance": HP, "width": WP}
    assert data["near"] == 10.0 and data["far"] is None  # null: infinitely far
    assert data["warnings"] == [warning]
    assert data["monotone"] is True and data["diverges"] is False
    cps = data["control_points"]
    assert [list(c) for c in cps] == [["disparity", "value", "slope"]] * 2
    # S0 Eq. (1a), (7), (9): d_e = (b/W)(1 - H/z_e), psi(d_e) = (b'/W')(1 - H'/z'_e), psi'(d_e) = rho z_e b'/(b_r z'_e).
    assert cps[0]["disparity"] == pytest.approx(0.0, abs=1e-15)
    assert cps[0]["value"] == pytest.approx(0.0, abs=1e-15)
    assert cps[0]["slope"] == pytest.approx(1.0 * 20 * BP / (B * 2.2), rel=RTOL)
    assert cps[1]["disparity"] == pytest.approx(B / W * (1 - H / 50), rel=RTOL)
    assert cps[1]["value"] == pytest.approx(BP / WP * (1 - HP / 4), rel=RTOL)
    samples = data["samples"]
    assert len(samples) >= 100
    assert all(list(s) == ["depth", "disparity", "mapped", "perceived_depth", "roundness"] for s in samples)
    # The scene depth of each sample (issue 9: omitted before): S0 Eq. (1a) inverted, null at infinity.
    assert samples[0]["depth"] == 10.0 and samples[-1]["depth"] is None
    for s in samples[1:-1]:
        assert B / W * (1 - H / s["depth"]) == pytest.approx(s["disparity"], rel=1e-9, abs=1e-15)
    d = np.array([s["disparity"] for s in samples])
    assert d[0] == pytest.approx(-0.2, rel=RTOL) and d[-1] == pytest.approx(0.2, rel=RTOL)
    assert np.all(np.diff(d) > 0)
    mapped = np.array([s["mapped"] for s in samples])
    np.testing.assert_allclose(mapped, _psi(d, cps), rtol=1e-10, atol=1e-14)
    for s, dd, m in zip(samples, d, mapped):
        z = B * H / (B - W * dd) if dd < B / W else math.inf  # S0 Eq. (1c)
        zp = BP * HP / (BP - WP * m)  # S0 Eq. (7)
        assert s["perceived_depth"] == pytest.approx(zp, rel=1e-10)
        slope = (_psi(np.array([dd + FD_STEP]), cps)[0] - _psi(np.array([dd - FD_STEP]), cps)[0]) / (2 * FD_STEP)
        rho = 0.0 if math.isinf(z) else B * HP * slope / (z * (BP - WP * m))  # S0 Eq. (9)
        if abs(dd) > 2 * FD_STEP and abs(dd - cps[1]["disparity"]) > 2 * FD_STEP:  # psi'' jumps at knots
            assert s["roundness"] == pytest.approx(rho, rel=FD_RTOL, abs=1e-12)
    middle = samples[len(samples) // 2]  # the subject: on the screen, roundness 1
    assert middle["perceived_depth"] == pytest.approx(HP, rel=1e-12)
    assert middle["roundness"] == pytest.approx(1.0, rel=1e-12)


def test_json_background_at_infinity_gives_null(capsys):
    # Tri-Rig (S0 §6, Fig. 8 right): background at infinity perceived at infinity -> psi(b_r/W) = b'/W'.
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2,roundness=1",
                        "--constraint", "z=inf,perceived=inf", "--near", "10", "--far", "inf", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["control_points"][1] == {"disparity": pytest.approx(B / W, rel=RTOL),
                                         "value": pytest.approx(BP / WP, rel=RTOL), "slope": 0.0}
    last = data["samples"][-1]
    assert last["mapped"] == pytest.approx(BP / WP, rel=RTOL)
    assert last["perceived_depth"] is None and last["roundness"] is None
    assert all(s["perceived_depth"] is not None for s in data["samples"][:-1])


def test_display_preset_and_b_div_reference(capsys):
    # tv-55: b' = 0.065, H' = 3, W' = 1.2176. Reference b_div = b'W/W' -> psi'(0) = f/f' (S0 §6).
    b_div = 0.065 * W / 1.2176
    code, out, _ = _run(capsys, "--reference-baseline", repr(b_div), "--convergence", str(H), "--window", str(W),
                        "--display", "tv-55", "--constraint", "z=20,perceived=3,roundness=1",
                        "--near", "12", "--far", "300", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["control_points"][0]["slope"] == pytest.approx((H / W) / (3.0 / 1.2176), rel=RTOL)
    assert data["samples"][-1]["disparity"] == pytest.approx(b_div / W * (1 - H / 300), rel=RTOL)


def test_summary_and_plot(capsys, tmp_path):
    plot = tmp_path / "psi.png"
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2,roundness=1",
                          "--constraint", "z=50,perceived=4", "--near", "10", "--far", "200", "--plot", str(plot))
    assert code == 0 and err.startswith("warning: mapped disparities from -0.2291") and err.count("\n") == 1
    assert "monotone: yes" in out and "control points" in out and f"plot written to {plot}" in out
    data = plot.read_bytes()
    assert data[:8] == PNG_SIGNATURE and len(data) > 20_000
    assert [p.name for p in tmp_path.iterdir()] == ["psi.png"]  # no temporary file left behind


def test_summary_shows_the_lowest_roundness(capsys):
    # Two round elements with a flat psi between them: the summary names the cardboard dip (rho < 0.3)
    # that the 11-row table may step over; its value and depth come from a dense scan of Eq. (9).
    from vergence.viewing.geometry import Display, Shooting
    from vergence.viewing.mapping import psi_from_constraints

    cons = ["z=20,perceived=2.2,roundness=1", "z=60,perceived=6,roundness=1"]
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", cons[0], "--constraint", cons[1],
                          "--near", "10", "--far", "100")
    assert code == 0 and err.startswith("warning: mapped disparities from -0.2291") and err.count("\n") == 1
    m = psi_from_constraints(Shooting(B, H, W), Display(BP, HP, WP), cons, near=10.0, far=100.0)
    z = np.geomspace(10.0, 100.0, 100_001)
    rho = m.roundness(z)
    assert rho.min() < 0.3  # the dip is real
    found = re.findall(r"^lowest roundness over the scene: ρ = (\S+) at z = (\S+) m \(cardboard, below 0.3\)$",
                       out, flags=re.MULTILINE)
    assert len(found) == 1
    assert float(found[0][0]) == pytest.approx(rho.min(), abs=5e-4)  # printed to 3 decimals
    assert float(found[0][1]) == pytest.approx(z[rho.argmin()], rel=1e-3)  # 4 significant digits, grid 1e-5


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--constraint", "z=20,perceivd=2"], "constraint 'z=20,perceivd=2' is malformed"),
        (["--constraint", "z=20,perceived=2", "--constraint", "z=40,perceived=1.5"],
         "perceived depths must increase with scene depth"),
        (["--constraint", "z=20,perceived=2,roundness=0"], "roundness must be > 0"),
        (["--constraint", "z=20,perceived=inf", "--constraint", "z=40,perceived=9"], "past the divergence limit"),
        (["--constraint", "z=-5,perceived=2"], "--constraint 'z=-5,perceived=2': z must be > 0"),
        (["--constraint", "z=500,perceived=9"], "lies outside the scene: near = 10, far = 100"),
    ],
)
def test_bad_constraints_exit_2_with_one_line(capsys, args, message):
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, *args, "--near", "10", "--far", "100", "--json")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("error: ")
    assert message in err


@pytest.mark.parametrize(
    ("display", "near_far", "message"),
    [
        (["--display", "tv-55", "--screen-width", "1"], ["--near", "10", "--far", "100"], "give either --display"),
        (["--eye-separation", "0.065"], ["--near", "10", "--far", "100"], "the display is incomplete"),
        (["--display", "imax"], ["--near", "10", "--far", "100"], "--display: unknown display preset 'imax'"),
        (DISPLAY_ARGS, ["--near", "100", "--far", "10"], "error: --far must be > --near 100; got 10"),
    ],
)
def test_bad_options_exit_2(capsys, display, near_far, message):
    code, _, err = _run(capsys, *RIG_ARGS, *display, "--constraint", "z=20,perceived=2", *near_far)
    assert code == 2 and err.count("\n") == 1 and message in err


def test_plot_must_be_png(capsys, tmp_path):
    code, _, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2", "--near", "10",
                        "--far", "100", "--plot", str(tmp_path / "psi.jpg"))
    assert code == 2 and err.startswith("error: --plot must end in .png")
    assert list(tmp_path.iterdir()) == []


def test_depth_option_answers_for_given_depths(capsys):
    # Issue 9: `mapping --depth 80` could not be asked. Identity-slope psi through (d(20), 0): the subject
    # at H on the screen; z = 20 gives d = 0, psi = 0, z' = H' (S0 Eq. 7); inf gives d = b_r/W = 0.2.
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2", "--near", "10",
                        "--far", "inf", "--depth", "20", "--depth", "80", "--depth", "inf", "--json")
    assert code == 0
    samples = json.loads(out)["samples"]
    assert [s["depth"] for s in samples] == [20.0, 80.0, None]
    assert samples[0]["disparity"] == 0.0 and samples[0]["perceived_depth"] == pytest.approx(HP, rel=RTOL)
    assert samples[1]["disparity"] == pytest.approx(B / W * (1 - H / 80), rel=RTOL)
    assert samples[2]["disparity"] == pytest.approx(B / W, rel=RTOL)
    code, out, _ = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2", "--near", "10",
                        "--far", "inf", "--depth", "80")
    assert code == 0 and "mapped depth at the given depths" in out and "80" in out
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2", "--near", "10",
                          "--far", "100", "--depth", "500")
    assert code == 2 and out == "" and err == "error: --depth must lie in the scene [10, 100] m (near, far); got 500\n"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        # issue 9: ZeroDivisionError, then "values must be finite"; Python's names instead of the options
        (["--window", "5e-324", "--constraint", "z=20,perceived=5e-324"],
         "error: --window must lie in [1e-06, 1e+06] m; got 4.94066e-324"),
        (["--window", str(W), "--constraint", "z=20,perceived=5e-324"],
         "error: --constraint 'z=20,perceived=5e-324': perceived must lie in [1e-06, 1e+20] m or be inf; "
         "got 4.94066e-324"),
        (["--window", str(W), "--constraint", "z=20,perceived=3,roundness=1e9"],
         "error: --constraint 'z=20,perceived=3,roundness=1e9': roundness must lie in [0.001, 1000]; got 1e+09 "
         "(psi' = roundness z b'/(b_r z'))"),
        (["--window", str(W), "--constraint", "z=20,perceived=3", "--viewing-distance", "-3"],
         "error: --viewing-distance must be > 0; got -3"),
        (["--window", str(W), "--constraint", "z=20,perceived=3", "--near", "1e-300"],
         "error: --near must lie in [1e-06, 1e+20] m; got 1e-300"),
    ],
)
def test_issue9_errors_name_the_options(capsys, args, message):
    base = ["--reference-baseline", str(B), "--convergence", str(H), "--eye-separation", str(BP),
            "--screen-width", str(WP)]
    if "--viewing-distance" not in args:
        base += ["--viewing-distance", str(HP)]
    if "--near" not in args:
        base += ["--near", "10"]
    code, out, err = _run(capsys, *base, *args, "--far", "100", "--json")
    assert code == 2 and out == "" and err == message + "\n"


def test_issue9_huge_roundness_is_refused_and_a_large_one_warns(capsys):
    # roundness=1e9 gave crossed disparities of -3e8 image widths, reported as fine. 1e3 is allowed
    # (ROUNDNESS_RANGE) but its mapped disparities leave the comfort zone: warned.
    code, out, err = _run(capsys, *RIG_ARGS, *DISPLAY_ARGS, "--constraint", "z=20,perceived=2.2,roundness=1000",
                          "--near", "10", "--far", "100", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["warnings"] and data["warnings"][0].startswith("mapped disparities from -")
    assert err == "".join(f"warning: {w}\n" for w in data["warnings"])
