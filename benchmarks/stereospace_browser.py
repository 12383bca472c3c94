"""Page 3's StereoSpace pair drawn in the browser (WebGL2) against the server's pair, in one process.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/stereospace_browser.py [--collection kermit] [--frames 30]
[--maps gpu]``
(``tabletop``: the built-in collection, ray-traced by the job; ``kermit`` or ``dino`` under
``../shared/data/collections``). Starts the workbench (uvicorn in a thread) and Debian's headless Chromium
(``/usr/bin/chromium``, WebGL2 on SwiftShader where there is no GPU), prepares the collection from the page,
then, interleaved round by round on the same states (a pan inside the start region, ``--frames`` states):

- the browser: one frame of the page's WebGL2 path (both eyes' camera and MLS plans, the shader passes, a
  one-pixel read-back so that the GPU's work is waited for) at the working width (a still frame), and one at the
  page's reduced width while the view moves (SS_MOTION_DIVISOR);
- the reference, what each key press cost before: ``POST /api/stereospace/{job}/pair`` (``stereo_pair`` on the
  server at the same width, anaglyph, PNG written) and the GET of its PNG.

Prints the medians and 95th percentiles, their ratio, the renderer and the load average (the 2 cores of the
development machine are shared: figures move by a factor of two between runs at load 7-8).
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from pathlib import Path

import httpx
import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "collections"
CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run"]
FRAME = """([state, moving]) => {
    SS.timing = true;
    const n = SS.frames.length;
    ssDrawState(state, moving);
    SS.timing = false;
    return SS.frames[n].ms;
}"""
# one frame with the GPU waited for after each stage (stereospace_gl.js drawCameras' profile): milliseconds per stage
PROFILE = """([state, moving]) => {
    const times = {}, full = Number(document.getElementById("ss-width").value);
    const width = moving ? Math.max(SS.result.min_width, Math.round(full / SS_MOTION_DIVISOR)) : full;
    const [a, b] = SSCams.eyeCameras(SS.gl.scene(), state);
    SS.gl.drawCameras(a, b, width, document.getElementById("ss-format").value, times);
    return times;
}"""


def _serve() -> tuple[object, str]:
    import uvicorn

    from vergence.web import create_app

    port = 43000 + os.getpid() % 1000
    server = uvicorn.Server(uvicorn.Config(create_app([DATA] if DATA.is_dir() else []), host="127.0.0.1", port=port,
                                           log_level="warning", lifespan="off"))  # fmt: skip
    threading.Thread(target=server.run, daemon=True).start()
    deadline = time.monotonic() + 20.0
    while not server.started:
        if time.monotonic() > deadline:
            raise SystemExit("the workbench server did not start")
        time.sleep(0.05)
    return server, f"http://127.0.0.1:{port}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", default="tabletop", help="tabletop (built in), kermit or dino")
    parser.add_argument("--frames", type=int, default=30, help="states along the pan (each timed both ways)")
    parser.add_argument("--maps", choices=("auto", "gpu", "js"), default="auto",
                        help="where the browser makes the MLS maps: the page's choice (auto: JavaScript on a software "
                             "GPU), a shader pass (gpu) or JavaScript (js)")
    parser.add_argument("--profile", action="store_true",
                        help="also time each stage of a frame (cameras, plans, maps, blend, pack) with the GPU waited "
                             "for after each, over the same states")
    args = parser.parse_args()
    if args.frames < 2:
        parser.error("--frames must be at least 2")
    from playwright.sync_api import sync_playwright

    server, url = _serve()
    cols = httpx.get(f"{url}/api/data", timeout=30).json()["collections"]
    wanted = "collection:tabletop" if args.collection == "tabletop" else f"{args.collection}/"
    entry = next((c for c in cols if c["id"] == wanted or c["name"].startswith(wanted)), None)
    if entry is None:
        raise SystemExit(f"no collection {args.collection!r} (the shared ones are read from {DATA})")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS, headless=True)
        page = browser.new_page(viewport={"width": 1280, "height": 1000})
        page.goto(url + "/#stereospace")
        page.wait_for_function("document.body.dataset.state === 'ready'", timeout=15_000)
        page.locator('[data-testid="ss-collection"]').select_option(entry["id"])
        page.click('[data-testid="ss-prepare"]')
        page.wait_for_function("SS.view !== null && document.body.dataset.state !== 'loading'", timeout=180_000)
        if page.evaluate("() => SS.gl === null"):
            raise SystemExit(page.locator('[data-testid="ss-renderer"]').inner_text())
        if args.maps != "auto":
            page.evaluate("(maps) => SS.gl.maps(maps)", args.maps)
        job = page.evaluate("() => SS.job")
        result = httpx.get(f"{url}/api/jobs/{job}", timeout=30).json()["result"]
        start, width = result["start"], result["default_width"]
        body = {"state": {k: start[k] for k in ("region", "li", "lj")}, "pan": start["pan_right"] * result["pan_step"]}
        end = httpx.post(f"{url}/api/stereospace/{job}/move", json=body, timeout=60).json()["steps"][0]["to"]
        if end["region"] != start["region"]:
            end = {**end, "region": start["region"], "li": start["li"], "lj": start["lj"]}
        browser_ms, motion_ms, server_ms, stages, motion_stages = [], [], [], [], []
        for k in range(args.frames + 1):  # the first round warms both up, untimed
            t = k / args.frames
            state = {"region": start["region"], "li": start["li"] + t * (end["li"] - start["li"]),
                     "lj": start["lj"] + t * (end["lj"] - start["lj"])}
            drawn = page.evaluate(FRAME, [state, False])
            moving = page.evaluate(FRAME, [state, True])
            t0 = time.perf_counter()
            answer = httpx.post(f"{url}/api/stereospace/{job}/pair",
                                json={"state": state, "format": "anaglyph", "width": width}, timeout=60).json()
            httpx.get(url + answer["images"]["packed"], timeout=60).raise_for_status()
            if k:
                browser_ms.append(drawn)
                motion_ms.append(moving)
                server_ms.append(1e3 * (time.perf_counter() - t0))
            if args.profile and k:
                stages.append(page.evaluate(PROFILE, [state, False]))
                motion_stages.append(page.evaluate(PROFILE, [state, True]))
        motion = page.evaluate("() => SS.frames[SS.frames.length - 1].width")
        name = page.evaluate("() => SS.gl.name")
        maps = page.evaluate("() => SS.gl.maps()")
        browser.close()
    server.should_exit = True
    b, m, s = np.array(browser_ms), np.array(motion_ms), np.array(server_ms)
    print(f"{entry['name']}: {result['cameras']} cameras, {result['points']} points, {width} px per eye, grid "
          f"{result['grid_step']}; renderer {name}, MLS maps on the {maps}")
    print(f"browser still frame (plans + draw, GPU waited for): median {np.median(b):.1f} ms, 95th percentile "
          f"{np.percentile(b, 95):.1f} ms over {len(b)} states")
    print(f"browser frame while moving (the page's motion frames, {motion} px per eye): median {np.median(m):.1f} ms, "
          f"95th percentile {np.percentile(m, 95):.1f} ms")
    print(f"server pair (POST .../pair + its PNG, the reference): median {np.median(s):.1f} ms, 95th percentile "
          f"{np.percentile(s, 95):.1f} ms")
    for kind, runs in (("still", stages), ("motion", motion_stages)):
        if runs:
            print(f"stages of a {kind} frame (GPU waited for after each; medians over the states, ms): " + ", ".join(
                f"{n} {np.median([st.get(n, 0.0) for st in runs]):.1f}" for n in runs[0])
                + f"; their sum {np.median([sum(st.values()) for st in runs]):.1f}")
    print(f"ratio server / browser (medians): {np.median(s) / np.median(b):.2f}; load average "
          f"{' '.join(open('/proc/loadavg').read().split()[:3])}")


if __name__ == "__main__":
    main()
