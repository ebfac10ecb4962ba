"""A headless browser for ``report --pdf``: Chromium (or Chrome, or Edge) prints the HTML
report as the reader would see it, with its fonts and images."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mechsolve.base.atomic import replacing
from mechsolve.base.errors import InputError

NAMES = (
    "chromium",
    "chromium-browser",
    "google-chrome",
    "google-chrome-stable",
    "chrome",
    "microsoft-edge",
    "msedge",
)
MAC_APPS = (
    "/Applications/Chromium.app/Contents/MacOS/Chromium",
    "/Applications/Google Chrome.app/Contents/MacOS/Google Chrome",
    "/Applications/Microsoft Edge.app/Contents/MacOS/Microsoft Edge",
)
INSTALL_HINT = (
    "install Chromium or Google Chrome (Debian/Ubuntu: apt-get install chromium; "
    "Fedora: dnf install chromium; macOS: brew install --cask chromium), or set "
    "MECHSOLVE_BROWSER to a Chromium-based browser; or open the HTML report and print it "
    "to PDF from the browser"
)
TIMEOUT = 180  # s


def find_browser() -> str | None:
    """The Chromium-based browser to run headless: ``$MECHSOLVE_BROWSER``, else the first
    of the usual names on the PATH (and the usual places on macOS), else None."""
    env = os.environ.get("MECHSOLVE_BROWSER")
    if env:
        return shutil.which(env) or (env if Path(env).is_file() else None)
    for name in NAMES:
        path = shutil.which(name)
        if path:
            return path
    if sys.platform == "darwin":
        for app in MAC_APPS:
            if Path(app).is_file():
                return app
    return None


def headless_command(browser: str, profile: str, *args: str) -> list[str]:
    """The command line of a headless run with its own throw-away profile (so that it
    does not meet a browser the user has open); without the sandbox when run as root
    (containers, CI), where Chromium refuses to start with it."""
    cmd = [browser, "--headless", "--disable-gpu", f"--user-data-dir={profile}"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--no-sandbox")
    cmd += ["--no-first-run", "--no-default-browser-check", *args]
    return cmd


def print_pdf(html: Path, pdf: Path, browser: str | None = None) -> Path:
    """Print ``html`` to ``pdf`` with a headless browser; the PDF appears only when it is
    complete. Raises :class:`InputError` saying what to install when there is none."""
    browser = browser or find_browser()
    if browser is None:
        raise InputError(f"--pdf: no headless browser found to print the PDF: {INSTALL_HINT}")
    html, pdf = Path(html).resolve(), Path(pdf)

    with replacing(pdf, ".pdf") as tmp:
        with tempfile.TemporaryDirectory(prefix="mechsolve-browser-") as profile:
            cmd = headless_command(
                browser,
                profile,
                "--no-pdf-header-footer",
                "--run-all-compositor-stages-before-draw",
                "--virtual-time-budget=5000",
                f"--print-to-pdf={tmp}",
                html.as_uri(),
            )
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT)
            except subprocess.TimeoutExpired:
                raise InputError(
                    f"--pdf: {browser} did not finish printing within {TIMEOUT} s"
                ) from None
            except OSError as exc:
                raise InputError(f"--pdf: cannot run {browser}: {exc.strerror or exc}") from None
        if proc.returncode != 0 or os.path.getsize(tmp) == 0:
            tail = "\n".join(proc.stderr.strip().splitlines()[-3:])
            raise InputError(f"--pdf: {browser} could not print the report: {tail}")
    return pdf
