"""Where the built site is, which of its files are pages, and how Chromium is started."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
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


def site_pages() -> list[str]:
    """Every HTML page of the built site, as a path relative to its root."""
    pages = [
        p.relative_to(SITE).as_posix()
        for p in sorted(SITE.rglob("*.html"))
        if p.relative_to(SITE).parts[0] not in SKIPPED_FOLDERS
    ]
    return pages
