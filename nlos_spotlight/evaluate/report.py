"""The report as a list of blocks, written as Markdown (``report.md``, PNGs beside it) and as a
self-contained HTML page (``report.html``, figures embedded as data URIs, opens offline)."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Block:
    """One piece of the report."""

    kind: str
    """'h1', 'h2', 'p', 'table', 'image' or 'code'."""
    text: str = ""
    """Heading or paragraph text, code, or the image caption."""
    header: list[str] = field(default_factory=list)
    """Table header."""
    rows: list[list[str]] = field(default_factory=list)
    """Table rows."""
    image: str = ""
    """Image file name, relative to the report folder."""


def to_markdown(blocks: list[Block]) -> str:
    out = []
    for b in blocks:
        if b.kind in ("h1", "h2"):
            out.append(("# " if b.kind == "h1" else "## ") + b.text)
        elif b.kind == "p":
            out.append(b.text)
        elif b.kind == "code":
            out.append(f"```\n{b.text}\n```")
        elif b.kind == "table":
            out.append("| " + " | ".join(b.header) + " |")
            out.append("|" + "---|" * len(b.header))
            out.extend("| " + " | ".join(r) + " |" for r in b.rows)
        elif b.kind == "image":
            out.append(f"![{b.text}]({b.image})\n\n*{b.text}*")
        out.append("")
    return "\n".join(out)


def to_html(blocks: list[Block], folder: Path, title: str) -> str:
    body = []
    for b in blocks:
        if b.kind in ("h1", "h2"):
            body.append(f"<{b.kind}>{html.escape(b.text)}</{b.kind}>")
        elif b.kind == "p":
            body.append(f"<p>{html.escape(b.text)}</p>")
        elif b.kind == "code":
            body.append(f"<pre>{html.escape(b.text)}</pre>")
        elif b.kind == "table":
            head = "".join(f"<th>{html.escape(h)}</th>" for h in b.header)
            rows = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in b.rows)
            body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>")
        elif b.kind == "image":
            data = base64.b64encode((folder / b.image).read_bytes()).decode()
            body.append(f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(b.text)}">'
                        f"<figcaption>{html.escape(b.text)}</figcaption></figure>")
    style = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;margin:1em 0;font-size:90%}td,th{border:1px solid #bbb;"
             "padding:3px 7px;text-align:right}th{background:#eee}img{max-width:100%}"
             "figcaption{font-style:italic;font-size:90%}pre{background:#f4f4f4;padding:.5em}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{style}</style></head><body>{''.join(body)}</body></html>")


def write_report(blocks: list[Block], folder: Path, title: str) -> tuple[Path, Path]:
    """Write report.md and report.html atomically; returns their paths."""
    paths = []
    for name, text in (("report.md", to_markdown(blocks)), ("report.html", to_html(blocks, folder, title))):
        p = folder / name
        tmp = p.with_name(f".{name}.tmp")
        tmp.write_text(text)
        tmp.replace(p)
        paths.append(p)
    return paths[0], paths[1]
