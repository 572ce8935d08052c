"""The built documentation site served on 127.0.0.1 and opened in headless Chromium.

``make docs-site`` builds the site into docs/_build/html; ``make docs-check`` builds it,
then runs these tests. Chromium is Debian's (``apt-get install chromium``), driven by
Playwright's Python package without a browser download of its own.
"""

from __future__ import annotations

import functools
import http.server
import threading
from collections.abc import Iterator

import pytest
from site_files import SITE, chromium


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 - the base class's name
        pass


@pytest.fixture(scope="session")
def site_url() -> Iterator[str]:
    """The site's root URL on a free port of 127.0.0.1, served from a thread."""
    if not (SITE / "index.html").is_file():
        pytest.fail(f"no built site in {SITE}: run `make docs-site` first")
    handler = functools.partial(_QuietHandler, directory=str(SITE))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


@pytest.fixture(scope="session")
def browser_context():
    """A Chromium context with a fresh profile, closed at the end of the session."""
    with chromium("docs-chromium-", viewport={"width": 1280, "height": 800}) as context:
        yield context
