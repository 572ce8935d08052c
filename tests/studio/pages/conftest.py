"""The studio served on a free port of 127.0.0.1 from a thread, and opened in headless
Chromium (Debian's, driven by Playwright's Python package, started as tests/docs/ starts
it). ``make studio-check`` runs these tests; they are not in the default suite."""

from __future__ import annotations

import shutil
import socket
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests" / "docs"))
from site_files import chromium  # noqa: E402

STARTUP_BOUND = 120.0
"""Seconds the server may take to start on a busy machine before the session gives up."""


@pytest.fixture(scope="session")
def studio_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scenarios")
    shutil.copy(ROOT / "scenarios" / "fruits_poisons.yaml", folder / "my_room.yaml")
    return folder


@pytest.fixture(scope="session")
def studio_url(studio_folder, tmp_path_factory) -> Iterator[str]:
    """The studio's root URL; the server runs in a thread of this process."""
    import uvicorn

    from flatland_ma.studio.app import create_app
    from flatland_ma.studio.config import Limits, StudioConfig

    scores = tmp_path_factory.mktemp("scores") / "play_scores.csv"
    config = StudioConfig(folders=(studio_folder,), scores=scores, limits=Limits(fps=30.0))
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(create_app(config), log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [listener]}, daemon=True)
    thread.start()
    waited = 0.0
    while not server.started and waited < STARTUP_BOUND:
        time.sleep(0.1)
        waited += 0.1
    if not server.started:
        pytest.fail("the studio did not start")
    try:
        yield f"http://127.0.0.1:{port}/"
    finally:
        server.should_exit = True
        thread.join(timeout=30)
        listener.close()


@pytest.fixture(scope="session")
def browser_context():
    """A Chromium context with a fresh profile, closed at the end of the session."""
    with chromium(
        "studio-chromium-", viewport={"width": 1280, "height": 900}, accept_downloads=True
    ) as context:
        yield context


@pytest.fixture
def page(browser_context, studio_url):
    """A fresh tab; the test fails if the page logged an error or threw."""
    tab = browser_context.new_page()
    errors: list[str] = []
    tab.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    tab.on("pageerror", lambda e: errors.append(str(e)))
    tab.studio_url = studio_url  # type: ignore[attr-defined]
    yield tab
    tab.close()
    assert errors == []
