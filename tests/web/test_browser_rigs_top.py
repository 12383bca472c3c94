"""Page 4's top view (issue 30) in Chromium: the rig drawn in the world's x-z plane over a metres grid.

Each camera's dot is read back in metres through the grid's own lines (their ``data-m`` and their position) and
compared with the camera centres of ``POST /api/rigs/plan``; every label's box (``getBBox``) lies inside the view
and meets none of the drawn lines (sampled along each line here, not with the page's clipping) nor another label.
"""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest

pytestmark = pytest.mark.browser

READY = "document.body.dataset.state === 'ready'"
AXES = {"x": 0, "y": 1, "z": 2}
DOT_TOL_PX = 0.01  # a dot's centre is the page's float coordinate: no rounding between the plan and the SVG
SAMPLE_PX = 0.25  # a line is sampled every quarter pixel against the labels' boxes

_VIEW = """(svg) => {
    const lines = [...svg.querySelectorAll('.rig-view line')].map((l) =>
        ['x1', 'y1', 'x2', 'y2'].map((a) => Number(l.getAttribute(a))));
    const grid = [...svg.querySelectorAll('line.grid')].map((l) => ({axis: l.dataset.axis, m: Number(l.dataset.m),
        px: Number(l.getAttribute(l.dataset.axis === 'h' ? 'x1' : 'y1'))}));
    const dots = [...svg.querySelectorAll('circle')].map((c) => ({name: c.dataset.camera || null,
        virtual: c.dataset.virtual || null, x: Number(c.getAttribute('cx')), y: Number(c.getAttribute('cy'))}));
    const labels = [...svg.querySelectorAll('.rig-labels text')].map((t) => {
        const b = t.getBBox();
        return {text: t.dataset.label, legend: t.dataset.legend === 'true', box: [b.x, b.y, b.width, b.height]};
    });
    const frame = svg.getBoundingClientRect();
    const texts = [...svg.querySelectorAll('text')].map((t) => {
        const r = t.getBoundingClientRect();
        return [r.left - frame.left, r.top - frame.top, r.right - frame.left, r.bottom - frame.top, t.textContent];
    });
    return {lines, grid, dots, labels, texts, size: [frame.width, frame.height], h: svg.dataset.hAxis,
            v: svg.dataset.vAxis};
}"""


def _metres(grid: list[dict], axis: str) -> tuple[float, float]:
    """The grid's px per metre along an axis (h: right, v: up) and the px of 0 m, from its first and last lines."""
    lines = sorted((g for g in grid if g["axis"] == axis), key=lambda g: g["m"])
    assert len(lines) >= 2, f"fewer than two grid lines along {axis}"
    a, b = lines[0], lines[-1]
    per_m = (b["px"] - a["px"]) / (b["m"] - a["m"])
    return per_m, a["px"] - a["m"] * per_m


def _struck(box: list[float], line: list[float]) -> bool:
    x, y, w, h = box
    x1, y1, x2, y2 = line
    n = max(2, int(np.hypot(x2 - x1, y2 - y1) / SAMPLE_PX) + 1)
    t = np.linspace(0.0, 1.0, n)
    px, py = x1 + t * (x2 - x1), y1 + t * (y2 - y1)
    return bool(np.any((px >= x) & (px <= x + w) & (py >= y) & (py <= y + h)))


def _check_view(page, testid: str, plan: dict) -> dict:
    svg = page.locator(f'[data-testid="{testid}"]')
    view = svg.evaluate(_VIEW)
    h, v = AXES[view["h"]], AXES[view["v"]]
    assert {view["h"], view["v"]} == {"x", "z"}  # the ground of a y-up shot
    hx, h0 = _metres(view["grid"], "h")
    vy, v0 = _metres(view["grid"], "v")
    assert hx > 0 and vy < 0  # h grows to the right, v upwards
    assert abs(hx) == pytest.approx(abs(vy), rel=1e-9)  # one scale: square metres
    centres = {c["name"]: c["camera"]["center"] for c in plan["cameras"]}
    virtual = ({"virtual left": plan["virtual"]["left"]["center"], "virtual right": plan["virtual"]["right"]["center"]}
               if plan["rig"] == "quadri" else {"reference right": plan["reference_right"]["center"]})
    seen = 0
    for dot in view["dots"]:
        centre = centres[dot["name"]] if dot["name"] else virtual[dot["virtual"]]
        assert dot["x"] == pytest.approx(h0 + hx * centre[h], abs=DOT_TOL_PX), dot
        assert dot["y"] == pytest.approx(v0 + vy * centre[v], abs=DOT_TOL_PX), dot
        seen += dot["name"] is not None
    assert seen == len(plan["cameras"])
    width, height = view["size"]
    for left, top, right, bottom, text in view["texts"]:  # nothing cut by the view's edges
        assert left >= 0 and top >= 0 and right <= width and bottom <= height, text
    placed = [label for label in view["labels"] if not label["legend"]]
    for i, label in enumerate(placed):
        for line in view["lines"]:
            assert not _struck(label["box"], line), (label["text"], line)
        for other in placed[i + 1:]:
            a, b = label["box"], other["box"]
            assert not (a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]), (
                label["text"], other["text"])
    return view


@pytest.mark.parametrize("preset", ["example:stadium-quadri", "example:stadium-tri"])
def test_the_top_view_is_in_metres_and_its_labels_are_clear(page, server_url, preset):
    page.goto(server_url + "/#rigs")
    page.wait_for_function(READY, timeout=15_000)
    if page.locator('[data-testid="rig-preset"]').input_value() != preset:
        page.select_option('[data-testid="rig-preset"]', preset)
        page.wait_for_function(READY, timeout=15_000)
    shot = json.loads(page.locator('[data-testid="rig-shot-json"]').text_content())
    plan = httpx.post(f"{server_url}/api/rigs/plan", json=shot, timeout=30).json()
    top = _check_view(page, "rig-top", plan)
    labels = {label["text"] for label in top["labels"]}
    if plan["rig"] == "quadri":  # every element and the convergence plane named, on the plot
        assert {e["name"] for e in plan["elements"]} | {f"convergence H_v = {shot['convergence']:g} m"} <= labels
    else:
        assert sum(text.startswith("z = ") for text in labels) == len(shot["constraints"])
        assert f"near z = {shot['near']:g} m" in labels  # the depth range's near end
    assert not any(label["legend"] for label in top["labels"]), top["labels"]
    close = _check_view(page, "rig-close", plan)
    named = " = ".join(label["text"] for label in close["labels"])
    assert all(c["name"] in named for c in plan["cameras"])


def test_crowded_labels_stay_clear_or_go_to_the_legend(page, server_url):
    """Thirty elements half a metre apart on the axis: their names cannot all sit on the plot; each is there clear
    of every line or in the legend under it, and nothing is cut by the view's edges."""
    page.goto(server_url + "/#rigs")
    page.wait_for_function(READY, timeout=15_000)
    page.evaluate("""() => {
        for (let i = 0; i < 30; i++) rigElementRow({ name: `crowded_element_${i}`, point: [0, 1, -40 - i / 2] });
        document.getElementById('rig-form').dispatchEvent(new Event('input'));
    }""")
    page.wait_for_function("document.querySelectorAll('#rig-top [data-element]').length === 32", timeout=15_000)
    page.wait_for_function(READY, timeout=15_000)
    shot = json.loads(page.locator('[data-testid="rig-shot-json"]').text_content())
    assert len(shot["elements"]) == 32
    plan = httpx.post(f"{server_url}/api/rigs/plan", json=shot, timeout=30).json()
    top = _check_view(page, "rig-top", plan)
    shown = [label["text"] for label in top["labels"]]
    expected = [e["name"] for e in shot["elements"]] + [f"convergence H_v = {shot['convergence']:g} m"]
    assert sorted(shown) == sorted(expected)
    legend = [label for label in top["labels"] if label["legend"]]
    assert legend and page.locator('[data-testid="rig-top"]').get_attribute("data-legend") == str(len(legend))
