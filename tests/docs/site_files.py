"""Where the built site is, which of its files are pages, and how Chromium is started."""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SITE = ROOT / "docs" / "_build" / "html"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
SKIPPED_FOLDERS = ("_static", "_sources", "_images")
"""Folders of the build that hold assets, not pages."""


@contextlib.contextmanager
def chromium(prefix: str, **options) -> Iterator:
    """A Playwright context of Debian's headless Chromium with a fresh profile (the docs'
    and the studio's checks both use it); ``options`` go to the launch (viewport, ...)."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory(prefix=prefix) as profile:
        with sync_playwright() as playwright:
            context = playwright.chromium.launch_persistent_context(
                profile, executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS, **options
            )
            # A bound for a page that never loads, generous for a busy 2-core machine.
            context.set_default_timeout(120_000)
            try:
                yield context
            finally:
                context.close()


def site_pages() -> list[str]:
    """Every HTML page of the built site, as a path relative to its root."""
    pages = [
        p.relative_to(SITE).as_posix()
        for p in sorted(SITE.rglob("*.html"))
        if p.relative_to(SITE).parts[0] not in SKIPPED_FOLDERS
    ]
    return pages
