"""Screenshots of the two HTML reports as headless Chromium draws them (``docs/report-*.png``).

    python docs/figures/report_screenshot.py [--fit out/fits/copyroom] [--demo out/demo/report]

The room model's report comes from ``python experiments/real-scan-fits/real_scan_fits.py`` (the copy room), the
evaluation report from ``make demo``. Each page is also checked the way the tests check it: every
table, figure and heading laid out and every image decoded.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nlos_spotlight.evaluate.browser import inspect, screenshot


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fit", default="out/fits/copyroom", help="a room model folder (nlos fit --out)")
    ap.add_argument("--demo", default="out/demo/report", help="an evaluation report folder (make demo)")
    ap.add_argument("--out", default="docs")
    args = ap.parse_args()
    for name, folder, height in (("room-model", args.fit, 2600), ("evaluation", args.demo, 3200)):
        page = Path(folder) / "report.html"
        if not page.is_file():
            print(f"skip {name}: no {page}")
            continue
        got = inspect(page)
        bad = [i for i, (_, w, h) in enumerate(got["images"]) if w * h == 0]
        if bad:
            raise SystemExit(f"error: {page}: images {bad} did not decode in the browser")
        png = screenshot(page, Path(args.out) / f"report-{name}.png", height=height)
        print(f"{png}: {len(got['tables'])} tables, {got['figures']} figures, {len(got['headings'])} headings")


if __name__ == "__main__":
    main()
