"""Open a report in a real headless browser: what it laid out (tables, figures, decoded images) and a
screenshot. Used by the tests and by ``docs/figures/report_screenshot.py``; needs a Chromium on the
PATH (``chromium``, ``chromium-browser`` or ``google-chrome``, or ``$NLOS_CHROMIUM``)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

_PROBE = """<script>window.addEventListener('load', () => {
  const imgs = [...document.images];
  const r = {tables: [...document.querySelectorAll('table')].map(t => t.rows.length),
             figures: document.querySelectorAll('figure').length,
             images: imgs.map(i => [i.complete, i.naturalWidth, i.naturalHeight]),
             headings: [...document.querySelectorAll('h1,h2')].map(h => h.textContent)};
  const p = document.createElement('pre'); p.id = 'nlos-probe'; p.textContent = JSON.stringify(r);
  document.body.appendChild(p);
});</script>"""
"""Appended to a copy of the page (the report itself stays as written): the browser's own count of
what it parsed and decoded, written into the DOM that ``--dump-dom`` returns."""


def find_browser() -> str | None:
    """The Chromium to use, or None where there is none."""
    env = os.environ.get("NLOS_CHROMIUM")
    if env:
        return env
    return next((p for n in ("chromium", "chromium-browser", "google-chrome") if (p := shutil.which(n))), None)


def _run(args: list[str], timeout: float) -> str:
    browser = find_browser()
    if browser is None:
        raise FileNotFoundError("no Chromium found (install the system's chromium package or set NLOS_CHROMIUM)")
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--hide-scrollbars",
             "--virtual-time-budget=10000", "--allow-file-access-from-files"]
    with tempfile.TemporaryDirectory() as profile:  # a throwaway profile: nothing left in $HOME
        p = subprocess.run([browser, *flags, f"--user-data-dir={profile}", *args], capture_output=True, text=True,
                           timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError(f"chromium exited {p.returncode}: {p.stderr.strip().splitlines()[-1:]}")
    return p.stdout


def inspect(page: Path, timeout: float = 120) -> dict:
    """Load ``page`` (a copy with ``_PROBE`` appended) and return what the browser laid out:
    ``tables`` (rows per table), ``figures``, ``images`` ([complete, naturalWidth, naturalHeight]
    each) and ``headings``."""
    html = Path(page).read_text()
    with tempfile.TemporaryDirectory() as d:
        copy = Path(d) / "page.html"
        copy.write_text(html.replace("</body>", _PROBE + "</body>") if "</body>" in html else html + _PROBE)
        dom = _run(["--dump-dom", copy.as_uri()], timeout)
    m = re.search(r'<pre id="nlos-probe">(.*?)</pre>', dom, re.S)
    if m is None:
        raise RuntimeError(f"the page did not finish loading in the browser: {page}")
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<")
                      .replace("&gt;", ">"))


def screenshot(page: Path, png: Path, width: int = 1200, height: int = 2400, timeout: float = 120) -> Path:
    """A PNG of the page as the browser draws it, ``width`` x ``height`` CSS pixels."""
    png = Path(png).resolve()
    png.parent.mkdir(parents=True, exist_ok=True)
    _run([f"--screenshot={png}", f"--window-size={width},{height}", Path(page).resolve().as_uri()], timeout)
    if not png.is_file():
        raise RuntimeError(f"chromium wrote no screenshot for {page}")
    return png


__all__ = ["find_browser", "inspect", "screenshot"]
