"""A variant of the page's WebGL2 renderer against the page's own, in one headless Chromium page, alternating.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereospace_gl_ab.py VARIANT.js [--frames 10]``

``VARIANT.js`` is a copy of ``src/vergence/web/static/pages/stereospace_gl.js`` with a change to measure (its
``const SSGL =`` is renamed when it is loaded, so both live in the page). The workbench prepares the built-in
tabletop from page 3 (as ``benchmarks/stereospace_browser.py`` does), the variant loads the same scene on a
second canvas, and the two draw the same states one after the other (320 px, anaglyph), each frame profiled
stage by stage with the GPU waited for after each (``drawCameras``' profile). Prints each renderer's median
per stage, whether their left eyes are the same bytes, and the load average: on the shared 2-core machine the
figures of separate runs moved by a factor of two, while the two renderers of one run stay within 5 % of each
other when the variant is the page's file itself.
"""

from __future__ import annotations

import argparse
import base64
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import stereospace_browser as sb  # noqa: E402  (the workbench and Chromium set-up)

DRAW = """(n) => {
    const res = { page: [], variant: [] }, v = SS.view;
    for (let k = 0; k <= n; k++) {  // the first round warms both up, untimed
        const st = { region: v.region, li: Math.min(1, v.li + 0.01 * k), lj: Math.min(1, v.lj + 0.01 * k) };
        for (const [name, r] of [["page", SS.gl], ["variant", window.SSGLVariantRenderer]]) {
            const [a, b] = SSCams.eyeCameras(r.scene(), st), t = {};
            r.drawCameras(a, b, 320, "anaglyph", t);
            if (k) res[name].push(t);
        }
    }
    const eyes = [SS.gl, window.SSGLVariantRenderer].map((r) => r.readEye(0).rgba);
    return { res, eyes };
}"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("variant", type=Path, help="a copy of stereospace_gl.js with the change to measure")
    parser.add_argument("--frames", type=int, default=10, help="states drawn by each renderer")
    args = parser.parse_args()
    if not args.variant.is_file():
        parser.error(f"no file {args.variant}")
    if args.frames < 1:
        parser.error("--frames must be at least 1")
    text = args.variant.read_text()
    if "const SSGL = " not in text:
        parser.error(f"{args.variant} does not define const SSGL (a copy of stereospace_gl.js)")
    from playwright.sync_api import sync_playwright

    server, url = sb._serve()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=sb.CHROMIUM, args=sb.ARGS, headless=True)
        page = browser.new_page(viewport={"width": 1280, "height": 1000})
        page.goto(url + "/#stereospace")
        page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
        page.locator('[data-testid="ss-collection"]').select_option("collection:tabletop")
        page.click('[data-testid="ss-prepare"]')
        page.wait_for_function("SS.view !== null && document.body.dataset.state !== 'loading'", timeout=180_000)
        if page.evaluate("() => SS.gl === null"):
            raise SystemExit(page.locator('[data-testid="ss-renderer"]').inner_text())
        page.add_script_tag(content=text.replace("const SSGL = ", "window.SSGLVariant = ", 1))
        page.evaluate("""async () => { const c = document.createElement("canvas"); document.body.append(c);
            window.SSGLVariantRenderer = SSGLVariant.create(c);
            await SSGLVariantRenderer.load(await api(`/api/stereospace/${SS.job}/scene`)); }""")
        out = page.evaluate(DRAW, args.frames)
        browser.close()
    server.should_exit = True
    a, b = (np.frombuffer(base64.b64decode(e), np.uint8).astype(np.int16) for e in out["eyes"])
    print(f"left eyes: {'the same bytes' if np.array_equal(a, b) else f'differ by up to {np.abs(a - b).max()}'}")
    for name, runs in out["res"].items():
        print(f"{name}: " + ", ".join(f"{s} {np.median([r.get(s, 0.0) for r in runs]):.1f}" for s in runs[0])
              + f"; sum {np.median([sum(r.values()) for r in runs]):.1f} ms (medians over {len(runs)} frames)")
    print(f"load average {' '.join(open('/proc/loadavg').read().split()[:3])}")


if __name__ == "__main__":
    main()
