"""A report folder: PNG figures plus a Markdown summary and a self-contained HTML page.

The HTML embeds every figure as base64 so the single file can be mailed or opened anywhere.
Tables are real HTML tables (and Markdown pipe tables). Each figure carries its axis labels
and legend entries as data attributes (from the PNG's text chunk, see figures._finish),
so a browser test can check units and fits on the rendered page.
"""

from __future__ import annotations

import base64
import html
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from porosense.files import write_text
from porosense.report.figures import read_labels


@dataclass
class DataTable:
    """A caption, column headers and rows of cells (numbers are formatted with ``digits``)."""

    caption: str
    header: list
    rows: list
    digits: int = 2

    def cell(self, value) -> str:
        if isinstance(value, float):
            return f"{value:.{self.digits}f}"
        return str(value)

    def markdown(self) -> str:
        lines = [
            f"*{self.caption}*",
            "",
            "| " + " | ".join(map(str, self.header)) + " |",
            "|" + "|".join("---" for _ in self.header) + "|",
        ]
        lines += ["| " + " | ".join(self.cell(c) for c in row) + " |" for row in self.rows]
        return "\n".join(lines)

    def html(self) -> str:
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in self.header)
        body = "".join(
            "<tr>"
            + "".join(
                f'<td class="{"num" if isinstance(c, (int, float)) else "txt"}">{html.escape(self.cell(c))}</td>'
                for c in row
            )
            + "</tr>"
            for row in self.rows
        )
        return (
            f"<table><caption>{html.escape(self.caption)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>"
        )

    def to_dict(self) -> dict:
        return {"caption": self.caption, "header": list(self.header), "rows": [list(r) for r in self.rows]}


def text_table(text: str, caption: str = "") -> list[DataTable]:
    """Whitespace-aligned text tables (columns separated by 2+ spaces) as DataTables; blank lines split."""
    tables, block = [], []
    for line in text.splitlines() + [""]:
        if line.strip() and not set(line.strip()) <= {"-"}:
            block.append(line)
        elif block:
            rows = [re.split(r"\s{2,}", ln.strip()) for ln in block]
            width = max(len(r) for r in rows)
            rows = [r + [""] * (width - len(r)) for r in rows]
            tables.append(DataTable(caption, rows[0], rows[1:]))
            block = []
    return tables


@dataclass
class Section:
    """A heading, paragraphs, tables (DataTable, or preformatted text), and figures (PNG paths)."""

    heading: str
    text: str = ""
    table: str = ""  # preformatted (monospace) block, for text that is not a table
    figures: list[Path] = field(default_factory=list)
    tables: list[DataTable] = field(default_factory=list)


STYLE = (
    "body{font-family:system-ui,sans-serif;max-width:1150px;margin:2em auto;padding:0 1em;color:#222}"
    "pre{background:#f6f6f6;padding:.8em;overflow-x:auto;font-size:13px}"
    "table{border-collapse:collapse;margin:1em 0;font-size:14px}"
    "caption{caption-side:top;text-align:left;font-style:italic;padding-bottom:.3em}"
    "th,td{border:1px solid #ccc;padding:.25em .6em}th{background:#f0f0f0}"
    "td.num{text-align:right;font-variant-numeric:tabular-nums}"
    "img{max-width:100%;border:1px solid #ddd;margin:.5em 0}h2{border-bottom:1px solid #ddd}"
    "figcaption{font-size:13px;color:#555}"
)


def _labels(path: Path) -> dict:

    return read_labels(path)


def write_report(
    directory, title: str, sections: list[Section], *, intro: str = "", name: str = "summary"
) -> tuple[Path, Path]:
    """Write ``<name>.md`` and ``<name>.html`` into ``directory``; returns both paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    md = [f"# {title}", ""]
    if intro:
        md += [intro, ""]
    for s in sections:
        md += [f"## {s.heading}", ""]
        if s.text:
            md += [s.text, ""]
        for t in s.tables:
            md += [t.markdown(), ""]
        if s.table:
            md += ["```", s.table.rstrip(), "```", ""]
        for f in s.figures:
            md += [
                f"![{Path(f).stem}]({Path(f).relative_to(directory) if Path(f).is_relative_to(directory) else f})",
                "",
            ]
    md_path = directory / f"{name}.md"
    write_text(md_path, "\n".join(md))

    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{STYLE}</style>",
        "</head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    if intro:
        parts.append(f"<p>{html.escape(intro)}</p>")
    for s in sections:
        parts.append(f"<h2>{html.escape(s.heading)}</h2>")
        for para in filter(None, s.text.split("\n\n")):
            parts.append(f"<p>{html.escape(para)}</p>")
        for t in s.tables:
            parts.append(t.html())
        if s.table:
            parts.append(f"<pre>{html.escape(s.table)}</pre>")
        for f in s.figures:
            data = base64.b64encode(Path(f).read_bytes()).decode("ascii")
            labels = _labels(f)
            axes = labels.get("axes", [])
            caption = Path(f).stem.replace("_", " ")
            described = "; ".join(f"{a['ylabel']} against {a['xlabel']}" for a in axes if a.get("xlabel"))
            parts.append(
                f'<figure data-labels="{html.escape(json.dumps(labels))}">'
                f'<img alt="{html.escape(Path(f).stem)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{html.escape(caption)}{': ' + html.escape(described) if described else ''}"
                f"</figcaption></figure>"
            )
    # Marks the page once every figure has decoded, so a headless browser can check it.
    parts.append(
        "<script>window.addEventListener('load',function(){var i=document.images,n=0;"
        "for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0)n++;}"
        "document.body.setAttribute('data-figures-loaded',n+'/'+i.length);});</script>"
    )
    parts.append("</body></html>")
    html_path = directory / f"{name}.html"
    write_text(html_path, "\n".join(parts))
    return md_path, html_path
