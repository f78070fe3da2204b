"""Headless Chromium for report tests: the DOM after load, and a screenshot."""

from __future__ import annotations

import shutil
import subprocess

import pytest

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


def render(page, profile, screenshot=None, size="1200,6000") -> str:
    """The DOM of ``page`` after its scripts ran (and a PNG at ``screenshot``); skips without chromium."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("chromium is not installed (tools/bootstrap.sh installs it)")
    flags = CHROMIUM_FLAGS + [f"--user-data-dir={profile}"]
    dom = subprocess.run(
        [browser, *flags, "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120
    ).stdout
    if screenshot is not None:
        subprocess.run(
            [browser, *flags, f"--screenshot={screenshot}", f"--window-size={size}", page.as_uri()],
            capture_output=True,
            timeout=120,
        )
    return dom
