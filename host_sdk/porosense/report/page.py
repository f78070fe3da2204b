"""A report folder: PNG figures plus a Markdown summary and a self-contained HTML page.

The HTML embeds every figure as base64 so the single file can be mailed or opened anywhere.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Section:
    """A heading, paragraphs or preformatted tables, and figures (PNG paths)."""

    heading: str
    text: str = ""
    table: str = ""  # preformatted (monospace) block
    figures: list[Path] = field(default_factory=list)


def write_report(directory, title: str, sections: list[Section], *, intro: str = "") -> tuple[Path, Path]:
    """Write ``summary.md`` and ``summary.html`` into ``directory``; returns both paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    md = [f"# {title}", ""]
    if intro:
        md += [intro, ""]
    for s in sections:
        md += [f"## {s.heading}", ""]
        if s.text:
            md += [s.text, ""]
        if s.table:
            md += ["```", s.table.rstrip(), "```", ""]
        for f in s.figures:
            md += [f"![{Path(f).stem}]({Path(f).relative_to(directory) if Path(f).is_relative_to(directory) else f})", ""]
    md_path = directory / "summary.md"
    md_path.write_text("\n".join(md))

    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
        "pre{background:#f6f6f6;padding:.8em;overflow-x:auto;font-size:13px}"
        "img{max-width:100%;border:1px solid #ddd;margin:.5em 0}h2{border-bottom:1px solid #ddd}</style>",
        "</head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    if intro:
        parts.append(f"<p>{html.escape(intro)}</p>")
    for s in sections:
        parts.append(f"<h2>{html.escape(s.heading)}</h2>")
        for para in filter(None, s.text.split("\n\n")):
            parts.append(f"<p>{html.escape(para)}</p>")
        if s.table:
            parts.append(f"<pre>{html.escape(s.table)}</pre>")
        for f in s.figures:
            data = base64.b64encode(Path(f).read_bytes()).decode("ascii")
            parts.append(f'<figure><img alt="{html.escape(Path(f).stem)}" src="data:image/png;base64,{data}">'
                         f"<figcaption>{html.escape(Path(f).stem.replace('_', ' '))}</figcaption></figure>")
    # Marks the page once every figure has decoded, so a headless browser can check it.
    parts.append("<script>window.addEventListener('load',function(){var i=document.images,n=0;"
                 "for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0)n++;}"
                 "document.body.setAttribute('data-figures-loaded',n+'/'+i.length);});</script>")
    parts.append("</body></html>")
    html_path = directory / "summary.html"
    html_path.write_text("\n".join(parts))
    return md_path, html_path
