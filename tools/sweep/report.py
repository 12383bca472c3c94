"""``report.json`` (every case) and ``summary.md`` (counts per class per target, failing cases)."""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from dataclasses import asdict
from pathlib import Path

from tools.sweep.classify import CLASSES, Result, answer_error, error_line

COMMAND_CHARS = 400  # a reproducing command line longer than this (a 5,000-character value) is cut

# The part of the code base that owns a target: the lead routes failing cases by it.
AREAS = {
    "budget": "viewing/cli", "mapping": "viewing/cli", "vergence.viewing": "viewing/cli",
    "vergence.report": "viewing/cli", "vergence.cli": "viewing/cli",
    "render": "render/io", "vergence.render": "render/io", "vergence.io": "render/io",
    "match": "depth/metrics", "rectify": "depth/metrics", "evaluate-disparity": "depth/metrics",
    "compare": "depth/metrics", "vergence.depth": "depth/metrics", "vergence.metrics": "depth/metrics",
    "vergence.camera": "depth/metrics", "vergence.rigs": "depth/metrics",
    "synthesize": "synthesis/display", "interpolate": "synthesis/display", "vergence.synthesis": "synthesis/display",
    "vergence.display": "synthesis/display", "demo": "viewing/cli",
}


def area_of(result: Result) -> str:
    """The area owning ``result``'s target (command name, ``module.name``, or a web route: "web")."""
    if result.kind == "web":
        return "web"
    target = result.target
    for key in sorted(AREAS, key=len, reverse=True):
        if target == key or target.startswith(key + "."):
            return AREAS[key]
    return "other"


def counts(results: list[Result]) -> dict[str, int]:
    c = Counter(cls for r in results for cls in r.classes)
    return {cls: c.get(cls, 0) for cls in CLASSES}


def _first_line(result: Result) -> str:
    if result.kind == "web":
        if result.returncode is None:
            return (result.stderr.splitlines() or ["no answer"])[-1][:200]
        said = answer_error(result.stdout) or " ".join(result.stdout.split())
        extra = "".join(f" [{x}]" for x in (result.leaked, result.outside) if x)
        return f"{result.returncode}: {said}"[:200] + extra
    if result.kind == "api":
        if result.status == "raised":
            return f"{result.exc_type}: {result.stdout}"[:200]
        if result.warnings:
            return result.warnings[0][:200]
        return (f"returned ({result.degenerate})" if result.degenerate else "returned")[:200]
    line = error_line(result.stderr) or next((ln for ln in result.stderr.splitlines() if ln.strip()), "")
    extra = f" [{result.degenerate}]" if result.degenerate else ""
    return f"exit {result.returncode}: {line}"[:200] + extra


def write(folder: Path, results: list[Result], *, meta: dict) -> dict:
    """Write ``report.json`` and ``summary.md`` into ``folder``; return the totals."""
    total = counts(results)
    per_target: dict[str, dict[str, int]] = {}
    for target in sorted({r.target for r in results}):
        sub = counts([r for r in results if r.target == target])
        per_target[target] = {k: v for k, v in sub.items() if v}
    failing = [r for r in results if r.classes != ["ok"]]
    data = {**meta, "cases": len(results), "failing_cases": len(failing), "counts": total,
            "per_target": per_target, "results": [asdict(r) for r in results]}
    (folder / "report.json").write_text(json.dumps(data, indent=1, default=str))

    api_bases = [r for r in results if r.kind == "api" and r.id.endswith("/base")]
    web_bases = [r for r in results if r.kind == "web" and r.id.endswith("/base")]
    web_targets = {r.target for r in results if r.kind == "web" and not r.id.startswith("web/setup/")}
    lines = [f"# Sweep summary: {len(results)} cases in {meta.get('runs', '?')} runs, {len(failing)} failing",
             "", f"Command: `{meta.get('command', '')}`  ", f"Duration: {meta.get('seconds', 0):.0f} s; "
             f"kinds: {dict(Counter(r.kind for r in results))}  ",
             # A hostile API argument tests that argument only where the guessed valid call succeeds.
             *([f"API names whose guessed valid call returned: {sum(r.status == 'returned' for r in api_bases)} "
                f"of {len(api_bases)} (the others raised ValueError/TypeError on our guess)  "] if api_bases else []),
             # A hostile body field tests that field only where the valid base request reaches the work.
             *([f"Web: {len(web_targets)} routes (POST /api/jobs/{{kind}} once per kind); valid base requests "
                f"answered 2xx: "
                f"{sum(r.returncode is not None and 200 <= r.returncode < 300 for r in web_bases)} of "
                f"{len(web_bases)} (the others name an id that stands for nothing: the route's own refusal)"]
               if web_bases else []), "",
             "| class | cases |", "|---|---|", *[f"| {k} | {v} |" for k, v in total.items()], "",
             "## Per target (classes other than ok)", "", "| target | area | classes |", "|---|---|---|"]
    for target, sub in per_target.items():
        bad = {k: v for k, v in sub.items() if k != "ok"}
        if bad:
            area = area_of(next(r for r in results if r.target == target))
            lines.append(f"| {target} | {area} | {', '.join(f'{k} {v}' for k, v in bad.items())} |")
    lines += ["", "## Failing cases by area", ""]
    by_area: dict[str, list[Result]] = defaultdict(list)
    for r in failing:
        by_area[area_of(r)].append(r)
    for area in sorted(by_area):
        lines += [f"### {area} ({len(by_area[area])})", ""]
        for r in by_area[area]:
            lines.append(f"- `{r.id}` **{', '.join(r.classes)}**: {_first_line(r)}  ")
            shown = r.command_line if len(r.command_line) <= COMMAND_CHARS else r.command_line[:COMMAND_CHARS] + " ..."
            lines.append(f"  `{shown}`")
        lines.append("")
    (folder / "summary.md").write_text("\n".join(lines) + "\n")
    return {"cases": len(results), "failing": len(failing), "counts": total}
