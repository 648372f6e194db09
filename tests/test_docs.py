"""The documents a newcomer reads: the contract they cite is in the repository, and their links resolve."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PREFACE_END = "-->\n\n"


def test_the_contract_in_the_repository_is_the_shared_one():
    """docs/design.md is ../shared/DESIGN.md below its preface (copy the shared file again when it changes)."""
    shared = ROOT.parent / "shared" / "DESIGN.md"
    if not shared.exists():
        pytest.skip("no ../shared/DESIGN.md beside this checkout")
    ours = (ROOT / "docs" / "design.md").read_text()
    assert ours.startswith("<!--") and PREFACE_END in ours
    assert ours.split(PREFACE_END, 1)[1] == shared.read_text(), \
        "../shared/DESIGN.md changed: copy it below docs/design.md's preface"


def _documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "experiments").rglob("*.md"))]


def test_every_relative_link_resolves():
    """Markdown links to files in the repository point at files that exist (web links and anchors aside)."""
    missing, docs = [], _documents()
    for doc in docs:
        for m in re.finditer(r"\]\(([^)\s]+)\)", doc.read_text()):
            link = m.group(1).split("#")[0]
            if not link or re.match(r"[a-z][a-z0-9+.-]*:", link):
                continue
            if not (doc.parent / link).exists():
                missing.append(f"{doc.relative_to(ROOT)}: {m.group(1)}")
    assert len(docs) > 10 and not missing, missing
