"""Shared fixtures: small scenes built in code."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from nlos_spotlight.scene.builders import quad
from nlos_spotlight.scene.format import Ambient, Camera, Human, Material, Projector, Scene, Shape


def plate_scene(res: int = 3, fov: float = 2.0, plate_albedo=0.0, hidden=1.0, kd=0.8) -> Scene:
    """A diffuse wall (y = 0, facing +y), a camera looking at (0, 0, 1) from the side, and a
    1 m x 1 m 'person' plate parallel to the wall at distance 1, centered in front of (0, 0, 1)."""
    wall = quad([-3, 0, -1], [6, 0, 0], [0, 0, 4], 6, 4)
    plate = quad([-0.5, 1.0, 0.5], [1, 0, 0], [0, 0, 1], 8, 8)
    cam = Camera(np.array([2.5, 1.2, 1.0]), np.array([0.0, 0.0, 1.0]), np.array([0, 0, 1.0]), fov, res, res)
    proj = Projector(np.array([1.0, 3.0, 1.0]), np.full(3, 10.0), 20.0, 30.0)
    sc = Scene([Shape("wall.ply", "paint", wall)], {"paint": Material(np.full(3, kd))}, cam, proj,
               ambient=Ambient(np.zeros(3), np.full(3, hidden)))
    sc.human = Human("plate.ply", np.full(3, plate_albedo), plate)
    return sc


@pytest.fixture
def small_corner():
    from nlos_spotlight.scene.examples import corner_scene

    return corner_scene("furniture", resolution=8)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)
    np.random.seed(0)


def _expected_layout(page) -> dict:
    """What a report page holds, read from its source with the standard library's HTML parser (the
    independent count the browser must agree with): rows per table, figures, PNG sizes, headings."""
    import base64
    import html.parser
    import struct

    class Count(html.parser.HTMLParser):
        def __init__(self):
            super().__init__()
            self.r = {"tables": [], "figures": 0, "images": [], "headings": []}
            self.heading = None

        def handle_starttag(self, tag, attrs):
            if tag == "table":
                self.r["tables"].append(0)
            elif tag == "tr":
                self.r["tables"][-1] += 1
            elif tag == "figure":
                self.r["figures"] += 1
            elif tag == "img":
                png = base64.b64decode(dict(attrs)["src"].split(",", 1)[1])
                self.r["images"].append([True, *struct.unpack(">II", png[16:24])])  # the IHDR width, height
            elif tag in ("h1", "h2"):
                self.heading = ""

        def handle_data(self, data):
            if self.heading is not None:
                self.heading += data

        def handle_endtag(self, tag):
            if tag in ("h1", "h2"):
                self.r["headings"].append(self.heading)
                self.heading = None

    c = Count()
    c.feed(page.read_text())
    return c.r


@pytest.fixture
def check_in_browser():
    """``check(report.html)``: load the page in headless Chromium and assert that it laid out every
    table (with all its rows), every figure and heading, and decoded every image at its PNG size.
    Skipped where no Chromium is installed (``apt-get install chromium``)."""
    from nlos_spotlight.evaluate.browser import find_browser, inspect

    if find_browser() is None:
        pytest.skip("no Chromium on this machine (apt-get install chromium)")

    def check(page):
        want, got = _expected_layout(page), inspect(page)
        assert want["tables"] and want["images"]
        assert got == want
        return got

    return check
