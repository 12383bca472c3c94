"""The sweep harness (tools/sweep): its classifier on hand-made outcomes, and one tiny real run."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from tools.sweep import sweep
from tools.sweep.api_driver import degenerate
from tools.sweep.classify import CLASSES, Result, classify, discount_degenerate_bases, python_name_in
from tools.sweep.cli_cases import BASES, Case, _replace_option, command_tree
from tools.sweep.hostile import HUGE_SIDE, hostile_files
from tools.sweep.runner import Limits, _api_result, _degenerate_file, inconsistent_json, prepare, run_cli

NAMES = frozenset({"distance", "width", "win_size", "min_contrast", "sigma", "image"})
ONE_LINE = "error: --viewing-distance must be > 0; got -3\n"


def _cli(**fields) -> Result:
    base = dict(id="cli/x/y", kind="cli", target="budget", returncode=2, stderr=ONE_LINE, hostile=True)
    return Result(**{**base, **fields})


def _web(**fields) -> Result:
    base = dict(id="web/POST /api/budget/baseline=text", kind="web", target="POST /api/budget", returncode=422,
                stdout='{"error":"baseline: expected a number (got \'abc\')"}', hostile=True, strict=True)
    return Result(**{**base, **fields})


def _api(**fields) -> Result:
    base = dict(id="api/f/p=nan", kind="api", target="vergence.viewing.f", status="raised", exc_type="ValueError",
                expected=True, hostile=True)
    return Result(**{**base, **fields})


# Each class with a hand-made outcome that shows it (and only the mistake it names).
FIRING = {
    "internal_error": _cli(returncode=1, stderr="error: internal error, please report it: ZeroDivisionError\n"),
    "traceback": _cli(returncode=2, stderr="Traceback (most recent call last):\n  File x\nKeyError: 1\n"),
    "timeout": _cli(returncode=-9, timed_out=True, stderr=""),
    "killed": _cli(returncode=-11, stderr=""),
    "noisy_stderr": _cli(returncode=0, hostile=False,
                         stderr="x.py:3: RuntimeWarning: overflow encountered in multiply\n"),
    "python_name": _cli(stderr="error: distance must be > 0; got -3\n"),
    "suspicious_ok": _cli(returncode=0, stderr="", degenerate="left.png: constant 0"),
    "input_modified": _cli(inputs_changed=["in/image.png"]),
    "leftovers": _cli(leftovers=[".out.tmp-1234.png"]),
    # exit 0 after Ctrl-C with an output missing: the interrupt was swallowed
    "sigint": _cli(kind="sigint", hostile=False, sigint_sent=True, returncode=0, stderr="", missing_outputs=["a.png"]),
    # web requests (issue 29)
    "server_error": _web(returncode=500, stdout='{"error":"internal error, please report it: KeyError: 1"}'),
    "accepted_hostile": _web(returncode=200, stdout='{"status":"ok"}', expect=(400,)),  # a foreign Host served
    "path_leak": _web(leaked="the data folder (/tmp/x/data)"),
    "hang": _web(returncode=None, timed_out=True, stdout=""),
    "not_one_line": _web(returncode=404, stdout='{"detail":"Not Found"}'),
}


@pytest.mark.parametrize("cls", sorted(FIRING))
def test_each_class_fires_on_its_own_mistake(cls):
    assert classify(FIRING[cls], names=NAMES) == [cls]


def test_every_class_but_ok_has_a_firing_example():
    assert set(FIRING) == set(CLASSES) - {"ok"}


@pytest.mark.parametrize("result", [
    _cli(),  # one line naming the option, exit 2
    _cli(returncode=2, stderr="error: Invalid value for '--baseline': 'abc' is not a valid float.\n"),
    _cli(returncode=0, stderr="", hostile=False),
    _cli(returncode=0, stderr="warning: the parallax leaves the comfort zone\n", hostile=True),  # our own warning
    _cli(kind="sigint", hostile=False, sigint_sent=True, returncode=130, stderr="error: interrupted\n"),
    _cli(kind="sigint", hostile=False, sigint_sent=False, returncode=0, stderr=""),  # finished before Ctrl-C
    _cli(kind="sigint", hostile=False, sigint_sent=True, returncode=0, stderr=""),  # Ctrl-C after the work: all there
    _cli(returncode=2, stderr="error: image must be (H, W, 3); got (4, 4, 2)\n", arguments=("image",)),
    _api(),
    _api(status="returned", exc_type=None, hostile=False),
    _api(status="returned", exc_type=None, strict=False, degenerate=None),
    _api(status="setup_error"),
    _web(),  # a clearly invalid value refused in one line
    _web(returncode=200, stdout="{}", strict=False),  # an extreme but valid value answered
    _web(returncode=403, stdout='{"error":"POST from Origin \'null\' refused"}', expect=(403,)),
    _web(returncode=200, stdout='{"state":"failed","error":"depth must be at most 4; got 9"}', strict=False),
], ids=lambda r: f"{r.kind}-{r.returncode}-{r.status}-{(r.stderr or r.stdout)[:25]}")
def test_well_handled_outcomes_stay_ok(result):
    assert classify(result, names=NAMES) == ["ok"]


def test_api_outcomes():
    # An AttributeError on a string where a Display belongs is ours to fix; numpy warnings are noise;
    # a NaN accepted with a NaN result is suspicious; a hang or crash in the driver is its own class.
    assert classify(_api(exc_type="AttributeError", expected=False)) == ["internal_error"]
    assert classify(_api(warnings=["RuntimeWarning: overflow encountered in cast"])) == ["noisy_stderr"]
    assert classify(_api(status="returned", strict=True)) == ["suspicious_ok"]
    assert classify(_api(status="returned", degenerate="no finite value in the result")) == ["suspicious_ok"]
    assert classify(_api(status="crashed", returncode=-6)) == ["killed"]
    assert classify(_api(status="crashed", timed_out=True, returncode=-9)) == ["timeout"]


def test_a_degenerate_result_counts_only_when_the_valid_call_is_not_degenerate():
    nan = "no finite value in the result"
    results = [_api(id="api/f/base", status="returned", hostile=False, degenerate=nan),
               _api(id="api/f/d=one_d", status="returned", degenerate=nan),
               _api(id="api/g/base", target="vergence.viewing.g", status="returned", hostile=False),
               _api(id="api/g/d=all_nan", target="vergence.viewing.g", status="returned", degenerate=nan)]
    discount_degenerate_bases(results)
    assert [classify(r) for r in results] == [["ok"], ["ok"], ["ok"], ["suspicious_ok"]]


def test_an_all_nan_result_of_an_array_counts_only_for_a_content_less_array():
    # A negative depth map maps to NaN by convention (invalid = NaN); an all-NaN map or a NaN number
    # that comes back as NaN is a value where an error belongs (issue 9: fill_disparity, arcmin_from_pixels).
    event = {"status": "returned", "degenerate": "no finite value in the result"}

    def spec(token, kind):
        return {"id": f"api/f/x={token}", "module": "m", "name": "f", "param": "x", "token": token, "kind": kind}

    assert classify(_api_result(spec("negative", "array"), event)) == ["ok"]
    assert classify(_api_result(spec("all_nan", "array"), event)) == ["suspicious_ok"]
    assert classify(_api_result(spec("huge", "number"), event)) == ["suspicious_ok"]


def test_python_name_spots_the_parameter_not_the_option():
    assert python_name_in("distance must be > 0; got -3", NAMES) == "distance"
    assert python_name_in("width: must be finite", NAMES) == "width"
    assert python_name_in("win_size exceeds image extent", NAMES) == "win_size"
    assert python_name_in("expected min_contrast in [0, 0.5]", NAMES) == "min_contrast"
    assert python_name_in("--viewing-distance must be > 0", NAMES) is None
    assert python_name_in("--min-contrast must lie in [0, 0.5]", NAMES) is None
    assert python_name_in("cannot read /tmp/my_image_file.png", NAMES) is None
    assert python_name_in("image must be RGB", NAMES, ("image",)) is None


def test_degenerate_results():
    assert degenerate(np.full((3, 3), np.nan)) == "no finite value in the result"
    assert degenerate(float("nan")) == "no finite value in the result"
    assert degenerate((np.empty((0, 0)), np.empty(0))) is None  # elementwise on nothing: nothing
    assert degenerate(0.5, from_empty=True) == "a number computed from an empty array"
    assert degenerate(np.empty(0), from_empty=True) is None
    assert degenerate(np.zeros((4, 4, 3)), from_nan=True) == "a constant 0 made of an all-NaN array"
    assert degenerate(np.zeros((4, 4, 3))) is None
    assert degenerate(np.array([np.nan, 1.0])) is None
    assert degenerate(None) is None and degenerate("text") is None


def test_inconsistent_budget_json():
    # Issue 9: random extreme parameters gave a perceived depth of 0.0 and a "diverges" flag that
    # contradicted the figures; a consistent sample and non-JSON output pass.
    sample = {"depth": 5.0, "disparity": 0.04, "perceived_depth": 11.9, "roundness": 3.6, "diverges": False}
    assert inconsistent_json(json.dumps({"depths": [sample]})) is None
    assert inconsistent_json(json.dumps({"depths": [{**sample, "perceived_depth": None, "diverges": True}]})) is None
    assert "perceived_depth 0.0" in inconsistent_json(json.dumps({"depths": [{**sample, "perceived_depth": 0.0}]}))
    assert "diverges True" in inconsistent_json(json.dumps({"depths": [{**sample, "diverges": True}]}))
    assert inconsistent_json("PSNR 30 dB") is None


def test_black_views_are_degenerate_but_black_hole_masks_are_not(tmp_path):
    from PIL import Image

    black = np.zeros((8, 8, 3), np.uint8)
    mostly_black = black.copy()
    mostly_black[:2] = 200  # 75 % black
    for name, pixels in (("left.png", black), ("right.png", mostly_black), ("holes.png", black)):
        Image.fromarray(pixels).save(tmp_path / name)
    assert _degenerate_file(tmp_path / "left.png") == "left.png: constant 0"
    assert _degenerate_file(tmp_path / "right.png") == "right.png: 75 % black"
    assert _degenerate_file(tmp_path / "holes.png") is None
    (tmp_path / "broken.png").write_bytes(b"not a png")
    assert _degenerate_file(tmp_path / "broken.png") == "broken.png: unreadable (UnidentifiedImageError)"


def test_hostile_png_declares_ten_billion_pixels_in_a_few_bytes():
    data = hostile_files()["huge_png"]
    width, height = struct.unpack(">II", data[16:24])
    assert (width, height) == (HUGE_SIDE, HUGE_SIDE) and len(data) < 200


def test_every_command_with_a_base_is_found_in_the_command_tree():
    # Commands that load on demand (vergence.cli.COMMANDS) must still be swept, options and all.
    tree = command_tree()
    assert set(BASES) <= set(tree)
    assert all(tree[name] for name in BASES)


def test_replace_option_swaps_one_value_and_drops_excluded_options():
    base = ["--a", "1", "--b", "2", "--c", "3"]
    assert _replace_option(base, "--b", ["nan"], set()) == ["--a", "1", "--c", "3", "--b", "nan"]
    assert _replace_option(base, "--d", ["x"], {"--a", "--c"}) == ["--b", "2", "--d", "x"]
    assert _replace_option(base, "--b", [], set()) == ["--a", "1", "--c", "3"]


def test_a_tiny_real_run(tmp_path):
    # The valid base of `budget` through the whole pipeline (fixtures, subprocess, report), then a
    # command line the CLI refuses with one line naming the option (exit 2): both stay ok.
    totals = sweep(tmp_path, only=("budget",), limit=1, time_limit_s=60)
    report = json.loads((tmp_path / "report.json").read_text())
    assert totals["cases"] == 1 and report["results"][0]["id"] == "cli/budget/base"
    assert report["results"][0]["classes"] == ["ok"], report["results"][0]["stderr"]
    assert "| ok | 1 |" in (tmp_path / "summary.md").read_text()
    prepare(tmp_path)
    case = Case(id="cli/budget/baseline=word", kind="cli", target="budget",
                argv=("budget", "--baseline", "abc", "--convergence", "3", "--window", "1", "--display", "tv-55"))
    result = run_cli(case, tmp_path, 1, Limits(time_limit_s=60))
    assert result.returncode == 2 and "--baseline" in result.stderr
    assert classify(result) == ["ok"]
    assert not any((tmp_path / "cases").iterdir())  # the case folder is removed after the run


def test_folder_parameters_take_a_folder_and_refuse_files():
    """scene_from_dict(base_dir=<folder>) was a suspicious_ok: a folder is what base_dir wants."""
    from tools.sweep.api_cases import HOSTILE_TOKENS, param_kind

    assert param_kind("scene_from_dict", "base_dir", "str | Path | None") == "folder"
    assert param_kind("atomic_folder", "path", "str | os.PathLike[str]") == "folder"
    assert param_kind("load_scene", "path", "str | Path") == "path"
    assert "folder" in HOSTILE_TOKENS["folder"] and "nested_json!" in HOSTILE_TOKENS["folder"]


def test_name_only_paths_and_broadcasting_arrays_are_not_strict():
    """stores_integers(path=<missing>) and schlick(n1=<other shape>) were false suspicious_ok cases."""
    import random

    from tools.sweep.api_cases import api_case_specs, param_kind

    assert param_kind("stores_integers", "path", "str | os.PathLike[str]") == "out_path"
    specs = api_case_specs(quick=False, rng=random.Random(0))
    strict = {s["id"] for s in specs if s["name"] == "schlick" and str(s["token"]).endswith("!")}
    assert strict and not any("other_shape" in i for i in strict)


def test_web_outcomes():
    # a guard's case that reached the route (a 404 where the guard answers 415), data from outside, a job
    # whose status reports an internal error, a refusal over two lines, a traceback, no answer at all
    assert classify(_web(returncode=404, stdout='{"error":"x"}', expect=(415,))) == ["accepted_hostile"]
    assert classify(_web(returncode=200, stdout="{}", strict=False, outside="listed 'out_par.txt'")) == [
        "accepted_hostile"]
    assert classify(_web(returncode=200, stdout='{"state":"failed","error":"internal error, please report it: X"}',
                         strict=False)) == ["server_error"]
    assert classify(_web(stdout='{"error":"a\\nb"}')) == ["not_one_line"]
    assert classify(_web(stdout='{"error":"x","detail":"y"}')) == ["not_one_line"]
    assert classify(_web(returncode=500, stdout="Traceback (most recent call last):\n  File")) == [
        "server_error", "path_leak", "not_one_line"]
    assert classify(_web(returncode=None, stdout="", stderr="no answer: ConnectionResetError")) == ["server_error"]


def test_every_route_twin_and_job_kind_has_its_cases():
    """A route, a twin or a job kind added to the app without a valid base or cases is noticed here."""
    import random

    from tools.sweep.web_cases import JOB_BASES, TWIN_BASES, WebContext, route_table, web_cases
    from vergence.web import create_app

    app = create_app()
    assert set(TWIN_BASES) == set(app.state.twins) and set(JOB_BASES) == set(app.state.jobs.kinds)
    cases = web_cases(app, WebContext(ids={}, port=8765), quick=True, rng=random.Random(0))
    targets = {c.target for c in cases}
    for method, template in route_table(app):
        assert f"{method} {template}" in targets, (method, template)
        assert f"web/{method} {template}/Host=foreign" in {c.id for c in cases}
    posts = [c for c in cases if c.method == "POST" and c.id.endswith("/Content-Type=text_plain")]
    assert posts and all(c.expect == (415,) and c.strict for c in posts)
    assert len({c.id for c in cases}) == len(cases)
    field_cases = {c.id for c in cases if c.target == "POST /api/budget"}
    assert {"web/POST /api/budget/base", "web/POST /api/budget/body=over_limit_chunked"} <= field_cases
    assert sum(c.id.startswith("web/POST /api/budget/baseline=") for c in cases) == 2  # quick: two per field


def test_a_body_field_is_replaced_by_raw_json_at_any_depth():
    from tools.sweep.web_cases import _with

    base = {"state": {"region": [0, 0], "li": 0.0}, "pan": 0.1}
    assert json.loads(_with(base, ("state", "li"), '"nan"')) == {"state": {"region": [0, 0], "li": "nan"}, "pan": 0.1}
    assert _with(base, ("pan",), "NaN") == b'{"state": {"region": [0, 0], "li": 0.0}, "pan": NaN}'
    assert json.loads(_with(base, ("state",), None)) == {"pan": 0.1}
    assert base == {"state": {"region": [0, 0], "li": 0.0}, "pan": 0.1}  # the base is not modified


def test_the_web_sweep_catches_a_broken_host_guard_and_a_leaked_path(tmp_path, monkeypatch):
    """The web kind end to end on two routes, the app served by uvicorn on 127.0.0.1: with its Host check
    taken out (every Host served) and the data listing showing paths, the sweep reports both."""
    import vergence.web._guard as guard
    from vergence.web.data import DataEntry

    monkeypatch.setattr(guard, "host_allowed", lambda name, allowed=(): True)
    real = DataEntry.to_dict
    monkeypatch.setattr(DataEntry, "to_dict", lambda self: {**real(self), "folder": str(self.root)})
    totals = sweep(tmp_path, quick=True, only=("web", "health", "data"), web_time_limit_s=20)
    report = json.loads((tmp_path / "report.json").read_text())
    classes = {r["id"]: r["classes"] for r in report["results"]}
    assert classes["web/GET /api/health/Host=foreign"] == ["accepted_hostile"]
    assert classes["web/GET /api/data/Host=foreign"] == ["accepted_hostile", "path_leak"]
    assert classes["web/GET /api/data/base"] == classes["web/GET /api/data/{entry_id}/base"] == ["path_leak"]
    assert classes["web/GET /api/health/base"] == ["ok"]
    assert totals["counts"]["accepted_hostile"] >= 3 and totals["counts"]["path_leak"] >= 3
    assert {r["target"] for r in report["results"] if not r["id"].startswith("web/setup/")} == {
        "GET /api/health", "GET /api/data", "GET /api/data/{entry_id}"}
    summary = (tmp_path / "summary.md").read_text()
    assert "### web" in summary and "`web/GET /api/health/Host=foreign` **accepted_hostile**: 200" in summary
    assert not (tmp_path / "scratch" / "web").exists()  # the data folder is removed after the run


def test_a_request_past_its_time_limit_is_a_hang_and_the_sweep_goes_on(tmp_path):
    import time

    from tools.sweep.web_runner import run_web
    from vergence.web import create_app

    def slow_app(data_dirs):
        app = create_app(data_dirs)
        app.get("/api/slow")(lambda: time.sleep(3) or {"late": True})  # sync: a worker thread, the loop stays free
        app.router.routes.insert(0, app.router.routes.pop())  # before the app's catch-all /api/{command}
        return app

    prepare(tmp_path)
    results = {r.id: r for r in run_web(tmp_path, names=("slow",), time_limit_s=1.0, app_factory=slow_app)}
    assert classify(results["web/GET /api/slow/base"]) == ["hang"]
    assert classify(results["web/GET /api/slow/Host=foreign"]) == ["ok"]  # refused before the route, in time
