"""Does a slow call hold a fast one? The workbench's twins side by side (issue 29).

The server (``vergence.web.create_app``) runs in uvicorn on 127.0.0.1 in this process. A small
``POST /api/budget`` is timed alone, then again while ``--slow`` calls of ``POST /api/match`` (two
uploaded textured views, ``--size`` pixels wide, 128 disparities) run at once from other threads.
Before issue 29 the twins ran the CLI one at a time under a server-wide lock, so the small call
waited for every slow one (19.8 s behind a 23 s call); now it waits for no one. Printed: the
median and the largest latency of the small call alone and during the slow calls, and the slow
calls' own time; and what a list past ``MAX_LIST_ITEMS`` costs (refused before any work). Run:
``.venv/bin/python benchmarks/web_concurrency.py [--repeats N] [--slow N] [--size W]``.
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import threading
import time
import urllib.request

import numpy as np

BUDGET = {"baseline": 0.12, "convergence": 8, "window": 2.4, "display": "tv-55", "depth": [4, 8, 16]}


def _post(url: str, body: object, content_type: str = "application/json") -> tuple[int, float]:
    data = body if isinstance(body, bytes) else json.dumps(body).encode()
    request = urllib.request.Request(url, data=data, headers={"Content-Type": content_type}, method="POST")
    start = time.perf_counter()
    try:
        with urllib.request.urlopen(request, timeout=600) as response:
            response.read()
            status = response.status
    except urllib.error.HTTPError as exc:
        exc.read()
        status = exc.code
    return status, time.perf_counter() - start


def _png(array: np.ndarray) -> bytes:
    import cv2

    ok, data = cv2.imencode(".png", array)
    assert ok
    return data.tobytes()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15, help="small calls timed in each condition")
    parser.add_argument("--slow", type=int, default=2, help="slow calls running at once (at most MAX_CALLS - 1)")
    parser.add_argument("--size", type=int, default=1200, help="width of the matched views, pixels")
    args = parser.parse_args()

    import uvicorn

    from vergence.web import create_app

    try:
        from vergence.commands import MAX_LIST_ITEMS
        from vergence.web._slots import MAX_CALLS
    except ImportError:  # a tree from before issue 29 (git worktree), for the before/after figures
        MAX_LIST_ITEMS, MAX_CALLS = 1000, 4

    if not 1 <= args.slow < MAX_CALLS:
        parser.error(f"--slow must be in [1, {MAX_CALLS - 1}] (MAX_CALLS {MAX_CALLS} leaves one slot for the small call)")
    sock = socket.create_server(("127.0.0.1", 0))
    base = f"http://127.0.0.1:{sock.getsockname()[1]}"
    server = uvicorn.Server(uvicorn.Config(create_app(), log_level="warning", ws="none"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.02)
    try:
        rng = np.random.default_rng(3)
        h, w = (args.size * 2) // 3, args.size
        texture = (rng.random((h // 4, (w + 64) // 4)) * 255).astype(np.uint8).repeat(4, 0).repeat(4, 1)
        ids = []
        for view in (texture[:, :w], texture[:, 40:w + 40]):
            req = urllib.request.Request(f"{base}/api/uploads", data=_png(view), method="POST",
                                         headers={"Content-Type": "image/png"})
            with urllib.request.urlopen(req) as response:
                ids.append(json.load(response)["id"])
        match = {"left": ids[0], "right": ids[1], "max_disparity": 128}
        _post(f"{base}/api/budget", BUDGET)  # warm: imports and kernels of both calls
        status, slow_alone = _post(f"{base}/api/match", match)
        assert status == 200, status

        alone = [_post(f"{base}/api/budget", BUDGET)[1] for _ in range(args.repeats)]
        slow_times: list[float] = []
        slows = [threading.Thread(target=lambda: slow_times.append(_post(f"{base}/api/match", match)[1]))
                 for _ in range(args.slow)]
        for t in slows:
            t.start()
        time.sleep(0.2)  # the slow calls are in their slots
        during, start = [], time.perf_counter()
        while len(during) < args.repeats and any(t.is_alive() for t in slows):
            status, seconds = _post(f"{base}/api/budget", BUDGET)
            assert status == 200, status
            during.append(seconds)
        for t in slows:
            t.join()
        over = {**BUDGET, "depth": [1.0] * (MAX_LIST_ITEMS * 10)}
        status, refused_s = _post(f"{base}/api/budget", over)
    finally:
        server.should_exit = True
        thread.join(30)
        sock.close()

    print(f"small POST /api/budget alone: median {1e3 * statistics.median(alone):.1f} ms, max "
          f"{1e3 * max(alone):.1f} ms ({len(alone)} calls)")
    print(f"the same during {args.slow} POST /api/match ({w}x{h}, 128 disparities; alone {slow_alone:.2f} s, "
          f"during {', '.join(f'{s:.2f}' for s in slow_times)} s): median {1e3 * statistics.median(during):.1f} ms, "
          f"max {1e3 * max(during):.1f} ms ({len(during)} calls, {time.perf_counter() - start:.2f} s)")
    print(f"a budget of {MAX_LIST_ITEMS * 10} depths: {status} in {1e3 * refused_s:.1f} ms (MAX_LIST_ITEMS "
          f"{MAX_LIST_ITEMS}; 200 means it was computed)")


if __name__ == "__main__":
    main()
