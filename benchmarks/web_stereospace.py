"""The workbench's StereoSpace page (``vergence.web.stereospace_page``) timed through its API.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/web_stereospace.py [--grid-step 8] [--data DIR]``
(reads the collections under ``../shared/data/collections``, or ``$VERGENCE_SHARED_DATA/collections``).
For dino and kermit, through FastAPI's test client in one process: the ``stereospace`` job (load,
triangulate where the camera file has no points, prepare), the median of 12 small moves (pan and zoom
inside a region, as the arrow keys give them), the median of 5 pans that jump at a region's border
(after one untimed: the kernel's cache is loaded), and the median of 12 new pairs at 320 and 640 px
(the whole request; the ``stereo_pair`` and the packed PNG as the answer's ``seconds`` says).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before Numba starts its OpenMP threads (as the CLI)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid-step", type=int, default=8, help="the job's grid_step (the page's fast: 16)")
    parser.add_argument("--data", type=Path, default=None, help="the collections folder")
    args = parser.parse_args()
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated")
    from fastapi.testclient import TestClient

    from vergence.report.demo_stereospace import dino_folder
    from vergence.web import create_app

    folder = args.data or dino_folder().parent
    if not folder.is_dir():
        print(f"skipped: no collections folder at {folder} (see shared/data/SOURCES.md)")
        return
    print(f"load average {os.getloadavg()[0]:.1f}; grid_step {args.grid_step}")
    with TestClient(create_app([folder])) as c:
        for name in ("dino", "kermit"):
            ids = [x["id"] for x in c.get("/api/data").json()["collections"] if x["name"].startswith(f"{name}/")]
            if not ids:
                print(f"{name}: missing")
                continue
            t = time.perf_counter()
            job = c.post("/api/jobs/stereospace", json={"collection": ids[0], "grid_step": args.grid_step}).json()
            while (status := c.get(f"/api/jobs/{job['id']}").json())["state"] not in ("done", "failed", "cancelled"):
                time.sleep(0.02)
            prepare = time.perf_counter() - t
            if status["state"] != "done":
                print(f"{name}: {status['state']} {status['error']}")
                continue
            r, url = status["result"], f"/api/stereospace/{job['id']}"
            states, moves = [{k: r["start"][k] for k in ("region", "li", "lj")}], []
            for k in range(12):
                t = time.perf_counter()
                m = c.post(f"{url}/move", json={"state": states[-1], "pan": (-1) ** k * 0.2 * r["pan_step"],
                                                "zoom": 0.1 * r["zoom_step"]}).json()  # fmt: skip
                moves.append(time.perf_counter() - t)
                states.append({k2: m["state"][k2] for k2 in ("region", "li", "lj")})
            jumps, events = [], []
            for k in range(6):
                t = time.perf_counter()
                m = c.post(f"{url}/move", json={"state": states[k], "pan": (8 + k) * r["pan_step"]}).json()
                jumps.append(time.perf_counter() - t)
                events.append(m["event"])
            c.post(f"{url}/pair", json={"state": states[0], "width": 160})  # untimed: caches loaded
            pairs = {}
            for width in (320, 640):
                total, pair, png = [], [], []
                for s in states[1:]:
                    t = time.perf_counter()
                    a = c.post(f"{url}/pair", json={"state": s, "width": width}).json()
                    total.append(time.perf_counter() - t)
                    pair.append(a["seconds"]["pair"])
                    png.append(a["seconds"]["files"])
                pairs[width] = "/".join(f"{1000 * statistics.median(x):.0f}" for x in (total, pair, png))
            print(f"{name}: job {prepare:.2f} s; move {1000 * statistics.median(moves):.1f} ms; pan across a border "
                  f"{1000 * statistics.median(jumps[1:]):.0f} ms ({events.count('jumped')} of 6 jumped); pair ms "
                  f"request/stereo_pair/PNG: 320 px {pairs[320]}, 640 px {pairs[640]}")  # fmt: skip


if __name__ == "__main__":
    main()
