"""Headless Chromium for the tests that render a page (``test_html_report``, ``test_audit_html``).

Where no Chromium is installed, those tests are skipped with the reason below, so the README's
``python -m pytest -q`` passes on a fresh machine. ``.ci/run`` installs Chromium and sets
:data:`REQUIRE_VARIABLE` to ``1``: there a missing browser fails the test instead of skipping it.
"""

from __future__ import annotations

import os
import shutil

import pytest

__all__ = ["REQUIRE_VARIABLE", "chromium", "chromium_command"]

#: set to 1 (``.ci/run`` does) to make the browser tests fail, not skip, without Chromium
REQUIRE_VARIABLE = "GLOCAL_REQUIRE_BROWSER"

MISSING = "Chromium is not installed (`apt-get install -y chromium` on Debian; .ci/run installs it and makes this test mandatory)"


def chromium() -> str:
    """Path of the Chromium executable; skip the test without one (fail when it is required)."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        if os.environ.get(REQUIRE_VARIABLE, "") not in ("", "0"):
            pytest.fail(f"{MISSING}; {REQUIRE_VARIABLE} is set, so a browser is required")
        pytest.skip(MISSING)
    return exe


def chromium_command(profile: os.PathLike[str] | str) -> list[str]:
    """The headless command line shared by the browser tests (``profile``: a fresh user data folder)."""
    return [chromium(), "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run", f"--user-data-dir={profile}"]
