"""The sweep harness: hostile inputs for every ``vergence`` command, every public API name and every
route of the workbench.

``python -m tools.sweep --out DIR`` generates the cases (:mod:`tools.sweep.cli_cases`,
:mod:`tools.sweep.api_cases`, :mod:`tools.sweep.web_cases`), runs each in a subprocess under a time
and memory limit (:mod:`tools.sweep.runner`) or, for the workbench, as a request to the app served on
127.0.0.1 (:mod:`tools.sweep.web_runner`), sorts the outcomes into the classes of issues 9 and 29
(:mod:`tools.sweep.classify`) and writes ``DIR/report.json`` and ``DIR/summary.md``
(:mod:`tools.sweep.report`). See ``tools/sweep/BASELINE.md`` for the counts on main.
"""

from __future__ import annotations

import random
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

__all__ = ["sweep"]

KINDS = ("cli", "api", "sigint", "random", "web")
# Cases per kind in a quick sweep: hostile values drawn per option / per API parameter, Ctrl-C moments
# and random parameter sets; sized so that --quick --jobs 2 ends in under 5 minutes on 2 cores.
# (measured on the shared 2-core machine under load: 3 to 7 s per command line, imports included).
QUICK_PER_OPTION, QUICK_CLI_SAMPLE, QUICK_PER_PARAM, QUICK_SIGINT, QUICK_RANDOM = 1, 40, 2, 4, 6
FULL_SIGINT, FULL_RANDOM = 30, 200


def _selected(case_kind: str, target: str, only: tuple[str, ...]) -> bool:
    if not only:
        return True
    return case_kind in only or target in only or target.rsplit(".", 1)[-1] in only


def sweep(out: Path, *, quick: bool = False, jobs: int = 1, only: tuple[str, ...] = (), seed: int = 9,
          time_limit_s: float = 60.0, api_time_limit_s: float = 30.0, web_time_limit_s: float = 20.0,
          memory_gb: float = 8.0, limit: int | None = None, per_option: int | None = None, sample: int | None = None,
          command: str = "") -> dict:
    """Run the sweep into ``out`` and return the totals (cases, runs, failing, counts per class).

    ``per_option`` (hostile values per option, per API parameter and per web body field) and
    ``sample`` (command-line cases drawn besides the bases and the issue's cases) override the quick
    sweep's sizes. ``web_time_limit_s``: seconds per web request.
    """
    import time

    from tools.sweep import cli_cases, report
    from tools.sweep.api_cases import api_case_specs
    from tools.sweep.classify import classify, discount_degenerate_bases
    from tools.sweep.runner import Limits, prepare, run_api_batch, run_cli

    start = time.monotonic()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("cases", "scratch"):
        shutil.rmtree(out / stale, ignore_errors=True)
    prepare(out)
    rng = random.Random(seed)
    limits = Limits(time_limit_s=time_limit_s, memory_gb=memory_gb)
    api_limits = Limits(time_limit_s=api_time_limit_s, memory_gb=memory_gb)
    tree = cli_cases.command_tree()
    arguments = {cmd: tuple(p.name for p in params if p.param_type_name == "argument") for cmd, params in tree.items()}
    names = cli_cases.python_names(tree)

    cases = []
    if _kind_wanted("cli", only):
        cases += [c for c in cli_cases.cli_cases(quick=quick or per_option is not None or sample is not None,
                                                 rng=rng, per_option=per_option or QUICK_PER_OPTION,
                                                 sample=sample if sample is not None else
                                                 (QUICK_CLI_SAMPLE if quick else None))
                  if _selected("cli", c.target, only)]
    if _kind_wanted("sigint", only):
        cases += [c for c in cli_cases.sigint_cases(count=QUICK_SIGINT if quick else FULL_SIGINT, rng=rng)
                  if _selected("sigint", c.target, only)]
    if _kind_wanted("random", only):
        cases += [c for c in cli_cases.random_cases(count=QUICK_RANDOM if quick else FULL_RANDOM, rng=rng)
                  if _selected("random", c.target, only)]
    specs = []
    if _kind_wanted("api", only):
        specs = [s for s in api_case_specs(quick=quick or per_option is not None, rng=rng,
                                                per_param=per_option or QUICK_PER_PARAM)
                 if _selected("api", f"{s['module']}.{s['name']}", only)]
    if limit is not None:
        cases, specs = cases[:limit], specs[: max(0, limit - len(cases))]
    batches: dict[str, list[dict]] = {}
    for s in specs:
        batches.setdefault(s["module"], []).append(s)

    def run_one(item):
        index, case = item
        return [run_cli(case, out, index, limits, arguments.get(case.target, ()))], 1

    def run_batch(item):
        index, batch = item
        return run_api_batch(batch, out, index, api_limits)

    web_limit = None if limit is None else max(0, limit - len(cases) - len(specs))

    def run_web_kind():
        from tools.sweep.web_runner import run_web

        names = tuple(o for o in only if o not in KINDS)  # route names: budget, health, jobs, ...
        return run_web(out, quick=quick or per_option is not None, rng=random.Random(seed),
                       time_limit_s=web_time_limit_s, names=names, limit=web_limit, per_field=per_option), 1

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(run_web_kind)] if _kind_wanted("web", only) and web_limit != 0 else []
        futures += [pool.submit(run_batch, item) for item in enumerate(batches.values())]
        futures += [pool.submit(run_one, item) for item in enumerate(cases)]
        outcomes = [f.result() for f in futures]
    results = [r for rs, _ in outcomes for r in rs]
    runs = sum(n for _, n in outcomes)
    discount_degenerate_bases(results)
    for r in results:
        r.classes = classify(r, names=names)
    shutil.rmtree(out / "cases", ignore_errors=True)
    meta = {"command": command, "quick": quick, "seed": seed, "jobs": jobs, "runs": runs,
            "time_limit_s": time_limit_s, "api_time_limit_s": api_time_limit_s,
            "web_time_limit_s": web_time_limit_s, "memory_gb": memory_gb,
            "seconds": time.monotonic() - start}
    totals = report.write(out, results, meta=meta)
    return {**totals, "runs": runs}


def _kind_wanted(kind: str, only: tuple[str, ...]) -> bool:
    """A kind runs when nothing is selected, when it is named, or when a name (not a kind) is given."""
    return not only or kind in only or not any(o in KINDS for o in only)
