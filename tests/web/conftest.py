"""Fixtures of the workbench's browser tests: the app served by uvicorn, and a page in Debian's Chromium.

Each pytest-xdist worker starts its own server on a free port and its own browser; tests marked
``browser`` skip with a reason when ``vergence.web``, Playwright or ``/usr/bin/chromium`` is missing.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
# A sandbox-free, quiet, offline headless Chromium: no GPU, no QUIC, no background traffic or updates.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
SERVER_START_S = 20.0  # the app imports in well under a second; uvicorn binds at once
VIEWPORT = {"width": 1280, "height": 1000}


def shared_collections() -> Path | None:
    """The shared collections folder (kermit, dino) when it exists: ``$VERGENCE_SHARED_DATA/collections``,
    else ``<repository>/../shared/data/collections`` (the rule of
    :func:`vergence.report.demo_stereospace.dino_folder`); None without it."""
    from vergence.report.demo_stereospace import dino_folder

    folder = dino_folder().parent
    return folder if folder.is_dir() else None


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def server_url() -> Iterator[str]:
    """Base URL of ``vergence.web.create_app()`` served by uvicorn in a thread of this worker, with the
    shared collections folder as its data folder when it exists (:func:`shared_collections`)."""
    try:
        from vergence.web import create_app
    except ImportError as exc:
        pytest.skip(f"vergence.web cannot be imported ({exc}): the server is missing "
                    "or the web extra is not installed (make setup)")
    import uvicorn

    port = _free_port()
    folder = shared_collections()
    config = uvicorn.Config(create_app([folder] if folder else []), host="127.0.0.1", port=port, log_level="warning", lifespan="off")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, name=f"uvicorn-{port}", daemon=True)
    thread.start()
    deadline = time.monotonic() + SERVER_START_S
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            raise RuntimeError(f"the workbench server did not start on port {port}")
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=10)


@pytest.fixture(scope="session")
def _browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[object]:
    """Debian's Chromium driven by Playwright (its own browser download is not available here)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright not installed")
    if not CHROMIUM.is_file():
        pytest.skip("Debian's chromium not found at /usr/bin/chromium (make setup installs it)")
    profile = tmp_path_factory.mktemp("chromium-profile")  # a new, empty user-data dir per worker
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(profile), executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True,
            viewport=VIEWPORT)
        try:
            yield context
        finally:
            context.close()


@pytest.fixture
def page(_browser: object, server_url: str) -> Iterator[object]:
    """A fresh Playwright page (sync API) on the workbench's server; closed after the test."""
    pg = _browser.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda exc: errors.append(str(exc)))
    try:
        yield pg
    finally:
        pg.close()
    if errors:  # an uncaught JavaScript exception is a failure of the page, whatever the test checked
        pytest.fail(f"JavaScript errors on the page: {errors}")


@pytest.fixture
def check_screenshot(tmp_path: Path):
    """A function ``(page, name)``: a full-page screenshot that must not be blank (taller than 600 px,
    at least 1200 wide, pixel std > 0.01, more than 50 colours); with ``VERGENCE_UPDATE_SCREENSHOTS=1``
    it is also copied to ``docs/images/<name>`` (the README's), else a test run changes no tracked file."""
    import os
    import shutil

    import numpy as np

    from vergence.io import read_image

    def check(page: object, name: str) -> None:
        path = tmp_path / name
        page.screenshot(path=str(path), full_page=True)
        image = read_image(path)
        assert image.ndim == 3 and image.shape[0] > 600 and image.shape[1] >= 1200
        assert float(image.std()) > 0.01
        assert np.unique(image.reshape(-1, 3), axis=0).shape[0] > 50  # text, figures and panels, not one colour
        if os.environ.get("VERGENCE_UPDATE_SCREENSHOTS") == "1":
            target = Path(__file__).resolve().parents[2] / "docs" / "images" / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)

    return check
