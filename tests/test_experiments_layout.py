"""Experiments and benchmarks import the package, never one another (each folder runs on its own)."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p for d in ("experiments", "benchmarks") for p in (ROOT / d).rglob("*.py"))
LOCAL = {p.stem for p in SCRIPTS}


def imported_roots(path: Path) -> set[str]:
    """Top-level names of every import in a file (nested ones too), relative imports as '.'."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            out.add("." if node.level else node.module.split(".")[0])
    return out


def test_the_scan_finds_the_scripts():
    assert len(SCRIPTS) > 20 and "robustness" in LOCAL and "unseen_room_fit" in LOCAL


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_script_imports_no_other_script_and_leaves_sys_path_alone(path):
    roots = imported_roots(path)
    assert not roots & (LOCAL | {"."}), f"imports {sorted(roots & (LOCAL | {'.'}))}: move shared code into nlos_spotlight"
    assert "sys.path" not in path.read_text()
