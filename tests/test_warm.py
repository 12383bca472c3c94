"""The kernel warm-up (``vergence.warm``, ``vergence warm``), the user's kernel cache folder and the
console script's notice before a compilation (issues 29 and 31, "first use")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from types import MappingProxyType

import pytest

from vergence._cache import NUMBA_CACHE_ENV, numba_cache_dir, use_numba_cache_dir
from vergence.cli import main
from vergence.cli._compile_notice import NOTICE

SUBPROCESS_TIMEOUT_S = 300  # a cold cache compiles a group's kernels: tens of seconds on 2 shared cores


# ---------------------------------------------------------------- the cache folder rule


def test_cache_folder_is_under_xdg_cache_home_then_home():
    assert numba_cache_dir({"XDG_CACHE_HOME": "/var/cache/ada", "HOME": "/home/ada"}) == Path(
        "/var/cache/ada/vergence/numba")
    assert numba_cache_dir({"HOME": "/home/ada"}) == Path("/home/ada/.cache/vergence/numba")
    # XDG Base Directory Specification: an empty or relative XDG_CACHE_HOME is ignored
    assert numba_cache_dir({"XDG_CACHE_HOME": "", "HOME": "/home/ada"}) == Path("/home/ada/.cache/vergence/numba")
    assert numba_cache_dir({"XDG_CACHE_HOME": "rel/cache", "HOME": "/home/ada"}) == Path(
        "/home/ada/.cache/vergence/numba")


def test_a_folder_the_user_chose_wins():
    env = {NUMBA_CACHE_ENV: "/tmp/mine", "XDG_CACHE_HOME": "/var/cache/ada", "HOME": "/home/ada"}
    assert numba_cache_dir(env) == Path("/tmp/mine")
    assert use_numba_cache_dir(env) == Path("/tmp/mine")
    assert env[NUMBA_CACHE_ENV] == "/tmp/mine"


def test_use_sets_the_variable_and_makes_the_folder(tmp_path):
    env = {"XDG_CACHE_HOME": str(tmp_path / "xdg"), "HOME": str(tmp_path / "home")}
    folder = use_numba_cache_dir(env)
    assert folder == tmp_path / "xdg" / "vergence" / "numba"
    assert folder.is_dir()
    assert env[NUMBA_CACHE_ENV] == str(folder)


def test_a_folder_that_cannot_be_made_leaves_numba_its_default_with_one_warning(tmp_path, capsys):
    (tmp_path / "file").write_text("not a folder")
    env = {"XDG_CACHE_HOME": str(tmp_path / "file"), "HOME": str(tmp_path)}
    assert use_numba_cache_dir(env) is None
    assert NUMBA_CACHE_ENV not in env
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("warning: cannot use ")
    assert str(tmp_path / "file" / "vergence" / "numba") in err and NUMBA_CACHE_ENV in err


def _python(code: str, env: dict[str, str] | None = None, *args: str) -> subprocess.CompletedProcess[str]:
    full = {**os.environ, **(env or {})}
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args], env=full, capture_output=True,
                          text=True, timeout=SUBPROCESS_TIMEOUT_S)


def test_the_console_script_sets_the_folder_and_the_library_does_not(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != NUMBA_CACHE_ENV}
    env.update(XDG_CACHE_HOME=str(tmp_path / "xdg"))
    code = """
        import atexit, os, sys
        atexit.register(lambda: print(os.environ.get("NUMBA_CACHE_DIR")))
        from vergence.cli import entry
        sys.argv[0] = "vergence"
        entry()
    """
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code), "--help"], env=env, capture_output=True,
                            text=True, timeout=SUBPROCESS_TIMEOUT_S)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == str(tmp_path / "xdg" / "vergence" / "numba")
    env[NUMBA_CACHE_ENV] = str(tmp_path / "chosen")
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code), "--help"], env=env, capture_output=True,
                            text=True, timeout=SUBPROCESS_TIMEOUT_S)
    assert result.stdout.splitlines()[-1] == str(tmp_path / "chosen")
    # the library itself changes nothing
    env.pop(NUMBA_CACHE_ENV)
    code = ("import os; before = dict(os.environ); import vergence, vergence.warm, vergence._cache; "
            "assert dict(os.environ) == before, set(os.environ.items()) ^ set(before.items())")
    result = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


# ---------------------------------------------------------------- the notice before a compilation

_NOTICE_SCRIPT = """
    import sys
    from vergence.cli import _compile_notice
    if sys.argv[1] == "silent":
        _compile_notice.silence()
    _compile_notice.install()  # before Numba loads: the finder registers the listener
    sys.path.insert(0, sys.argv[2])
    import kernels  # a module of two cache=True kernels
    import numpy as np
    print(kernels.double(np.arange(3.0)).sum(), kernels.triple(2.0))
"""
_KERNELS = """
import numba

@numba.njit(cache=True)
def double(a):
    return 2 * a

@numba.njit(cache=True)
def triple(x):
    return 3 * x
"""


def test_the_notice_is_printed_once_when_something_compiles_and_never_for_cache_loads(tmp_path):
    (tmp_path / "kernels.py").write_text(_KERNELS)
    env = {NUMBA_CACHE_ENV: str(tmp_path / "cache")}
    first = _python(_NOTICE_SCRIPT, env, "say", str(tmp_path))
    assert first.returncode == 0, first.stderr
    assert first.stdout.split() == ["6.0", "6.0"]
    assert first.stderr == NOTICE + "\n"  # two kernels compiled, one line
    second = _python(_NOTICE_SCRIPT, env, "say", str(tmp_path))
    assert second.returncode == 0 and second.stderr == ""  # both loaded from the cache
    (tmp_path / "cache2").mkdir()
    silent = _python(_NOTICE_SCRIPT, {NUMBA_CACHE_ENV: str(tmp_path / "cache2")}, "silent", str(tmp_path))
    assert silent.returncode == 0 and silent.stderr == ""


def test_commands_that_use_no_kernel_do_not_load_numba():
    code = """
        import sys
        from vergence.cli import _compile_notice
        _compile_notice.install()
        from vergence.cli import main
        assert main(["budget", "--baseline", "0.65", "--convergence", "30", "--window", "3", "--display", "tv-55",
                     "--depth", "15", "--json"]) == 0
        print("numba" in sys.modules, file=sys.stderr)
    """
    result = _python(code)
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines()[-1] == "False"


# ---------------------------------------------------------------- warm()


def test_unknown_or_repeated_groups_are_refused_naming_the_table():
    from vergence.warm import WARM_GROUPS, warm

    with pytest.raises(ValueError, match=r"^groups must be names of WARM_GROUPS \(compare, .*video\); got 'nope'$"):
        warm(["nope"])
    with pytest.raises(ValueError, match="must not repeat"):
        warm(["compare", "compare"])
    assert list(WARM_GROUPS) == sorted(WARM_GROUPS)


def _fake_groups(monkeypatch, calls: list[str]) -> None:
    import vergence.warm as vw

    def run(name):
        return lambda folder: calls.append((name, folder.is_dir()))

    table = MappingProxyType({
        "a": vw.WarmGroup(run("a"), ("cmd a",)),
        "b": vw.WarmGroup(run("b"), ("cmd b",)),
        "x": vw.WarmGroup(run("x"), ("cmd x",), extra="nothing", module="vergence_no_such_module"),
    })
    monkeypatch.setattr(vw, "WARM_GROUPS", table)


def test_warm_runs_the_groups_in_order_reports_progress_and_leaves_out_missing_extras(monkeypatch):
    from vergence.warm import warm

    calls: list = []
    _fake_groups(monkeypatch, calls)
    seen: list = []
    seconds = warm(progress=lambda f, g: seen.append((f, g)))
    assert list(seconds) == ["a", "b"] and all(s >= 0 for s in seconds.values())
    assert calls == [("a", True), ("b", True)]  # each in an existing scratch folder
    assert seen == [(0.0, "a"), (0.5, "b"), (1.0, "")]
    with pytest.raises(ImportError, match=r"^warm-up group x needs the nothing extra: pip install 'vergence\[nothing\]'$"):
        warm(["x"])
    assert list(warm(["b", "a"])) == ["b", "a"]


def test_the_cli_prints_a_line_a_group_and_the_total(monkeypatch, capsys):
    import vergence.cli.warm as cli_warm
    import vergence.warm as vw

    calls: list = []
    _fake_groups(monkeypatch, calls)
    monkeypatch.setattr(cli_warm, "WARM_GROUPS", vw.WARM_GROUPS)
    assert main(["warm"]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0].startswith("warming 3 kernel group(s) into ")
    assert lines[1].startswith("a ") and lines[1].endswith(" s  (cmd a)")
    assert lines[2].startswith("b ") and lines[2].endswith(" s  (cmd b)")
    assert lines[3] == "x            skipped: needs the nothing extra: pip install 'vergence[nothing]'"
    assert lines[4].startswith("kernels ready in ") and len(lines) == 5
    assert err == ""
    assert main(["warm", "--group", "b"]) == 0
    assert [c[0] for c in calls] == ["a", "b", "b"]
    capsys.readouterr()
    assert main(["warm", "--group", "x"]) == 2
    assert capsys.readouterr().err.strip() == ("error: --group x needs the nothing extra: pip install "
                                               "'vergence[nothing]'")
    assert main(["warm", "--group", "nope"]) == 2
    assert capsys.readouterr().err.strip() == "error: --group must be one of a, b, x; got 'nope'"


# ---------------------------------------------------------------- a real command compiles nothing after its group

_AFTER_WARM = """
    import json, sys
    import numpy as np
    from vergence.warm import kernel_signatures, warm

    def misses():
        from numba.core.dispatcher import Dispatcher
        seen = {{}}
        for name, module in list(sys.modules.items()):
            if name.startswith("vergence.") and module is not None:
                for obj in vars(module).values():
                    if isinstance(obj, Dispatcher):
                        seen[id(obj)] = sum(obj.stats.cache_misses.values())
        return sum(seen.values())

    folder = sys.argv[1]
    {prepare}
    warm([{group!r}])
    warmed, missed = kernel_signatures(), misses()
    from vergence.cli import main
    code = main({argv})
    after = kernel_signatures()
    new = {{k: sorted(v - warmed.get(k, frozenset())) for k, v in after.items() if v - warmed.get(k, frozenset())}}
    print(json.dumps({{"code": code, "warmed": sorted(k for k, v in warmed.items() if v), "new": new,
                      "compiled": misses() - missed}}))
"""

_SYNTH_INPUTS = """
    from vergence.io import write_image, write_pfm
    rng = np.random.default_rng(7)
    write_image(folder + "/image.png", rng.random((50, 70, 3), dtype=np.float32))
    depth = np.full((50, 70), 3.0, dtype=np.float32)
    depth[10:30, 20:45] = 1.2
    depth[0, 0] = np.nan  # an unknown depth, as a render's background
    write_pfm(folder + "/depth.pfm", depth)
"""
_COMPARE_INPUTS = """
    from vergence.io import write_image
    rng = np.random.default_rng(8)
    write_image(folder + "/a.png", rng.random((40, 52, 3), dtype=np.float32))
    write_image(folder + "/b.png", rng.random((40, 52, 3), dtype=np.float32))
"""

# group, its inputs, the command, and kernels that command is known to run (the warm-up must have them)
_CASES = {
    "synthesize": (_SYNTH_INPUTS, ["synthesize", "{f}/image.png", "{f}/depth.pfm", "--out", "{f}/views",
                                   "--format", "anaglyph"],
                   {"vergence.synthesis._kernels.forward_warp_rows", "vergence.synthesis._kernels.fill_holes_rows",
                    "vergence._display_kernels.dubois"}),
    "compare": (_COMPARE_INPUTS, ["compare", "{f}/a.png", "{f}/b.png", "--json"],
                {"vergence._metrics_kernels.registration_search", "vergence._metrics_kernels.patch_sums"}),
}


@pytest.mark.parametrize("group", sorted(_CASES))
def test_after_its_group_a_real_command_compiles_nothing(group, tmp_path):
    prepare, argv, known = _CASES[group]
    argv = [a.format(f=tmp_path) for a in argv]
    script = _AFTER_WARM.format(prepare=textwrap.indent(textwrap.dedent(prepare), "    ").strip(), group=group,
                                argv=argv)
    result = _python(script, None, str(tmp_path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout.splitlines()[-1])
    assert report["code"] == 0
    assert known <= set(report["warmed"])  # the warm-up ran what the command runs ...
    assert report["new"] == {}  # ... with every specialisation the command needs
    assert report["compiled"] == 0
