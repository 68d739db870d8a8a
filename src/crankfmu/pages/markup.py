"""The HTML every page crankfmu writes shares: one stylesheet, one page shell, and the small
Markdown subset its reports are written in, rendered to HTML.

The results page (``crankfmu page``), the validation report's ``report.html`` and each FMU's
``documentation/index.html`` are self-contained files: no script, font or style from the network.
Each carries one inline script that marks, when the page has loaded, every image the browser could
not show (``data-broken-images`` on ``<body>``, and a visible line at the top), so a reader sees a
missing figure and a test in headless Chromium reads it from the page; it also writes the page's
laid-out width (``data-page-width``), so a test sees a page wider than a phone's screen.
"""

from __future__ import annotations

import html
import re

STYLE = """
body { font-family: system-ui, sans-serif; max-width: 72em; margin: 1em auto; padding: 0 1em; line-height: 1.45;
       color: #222; }
h1 { font-size: 1.7em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.15em; margin-top: 1.8em; }
table { border-collapse: collapse; font-size: 0.88em; margin: 0.6em 0; }
.scroll { overflow-x: auto; max-width: 100%; }
details { margin: 0.6em 0; } summary { cursor: pointer; color: #1a4f8a; }
td, th { border: 1px solid #bbb; padding: 2px 6px; vertical-align: top; text-align: left; }
th { background: #eee; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
code { background: #f3f3f3; padding: 0 0.2em; }
img { max-width: 100%; height: auto; }
figure { margin: 1.2em 0; } figcaption { font-size: 0.92em; color: #333; max-width: 60em; }
.note { color: #555; font-size: 0.92em; }
.broken { background: #fdd; padding: 0.4em; }
.verdict-agrees { color: #176117; font-weight: bold; } .verdict-disagrees { color: #9a4b00; font-weight: bold; }
.verdict-fitted { color: #555; font-weight: bold; } .verdict-changed { color: #b00; font-weight: bold; }
nav ul { columns: 2; } nav li { break-inside: avoid; }
@media (max-width: 600px) { nav ul { columns: 1; } }
math { font-size: 1.1em; } .equation { margin: 0.6em 0 0.6em 1.5em; }
"""

#: marks the images the browser could not load (see the module's docstring)
IMAGE_CHECK = """<script>
addEventListener("load", () => {
  const broken = [...document.images].filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute("src"));
  document.body.dataset.brokenImages = broken.join(" ");
  document.body.dataset.loadedImages = String(document.images.length - broken.length);
  document.body.dataset.pageWidth = String(document.documentElement.scrollWidth);
  if (broken.length) {
    const p = document.createElement("p");
    p.className = "broken";
    p.textContent = broken.length + " image(s) could not be loaded: " + broken.join(", ");
    document.body.prepend(p);
  }
});
</script>"""


def page(title: str, body: str) -> bytes:
    """A whole HTML document: the title, the shared style, ``body`` and the image check."""
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head>\n<body>\n{body}\n"
            f"{IMAGE_CHECK}\n</body></html>\n").encode()


def slug(text: str) -> str:
    """A heading's anchor as GitHub makes it (what report.md's links use): lower case, punctuation
    dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


_INLINE = re.compile(r"(`[^`]+`)|!\[([^\]]*)\]\(([^)]+)\)|\[([^\]]+)\]\(([^)]+)\)|\*\*(.+?)\*\*")


def inline(text: str) -> str:
    """Code spans, images, links and bold of one line; everything else escaped."""
    out, at = [], 0
    for m in _INLINE.finditer(text):
        out.append(html.escape(text[at:m.start()]))
        code, alt, src, label, href, bold = m.groups()
        if code:
            out.append(f"<code>{html.escape(code[1:-1])}</code>")
        elif src is not None:
            out.append(f'<img src="{html.escape(src)}" alt="{html.escape(alt)}">')
        elif label is not None:
            out.append(f'<a href="{html.escape(href)}">{inline(label)}</a>')
        else:
            out.append(f"<strong>{inline(bold)}</strong>")
        at = m.end()
    out.append(html.escape(text[at:]))
    return "".join(out)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def markdown(text: str) -> str:
    """HTML of the Markdown subset crankfmu's reports use: ATX headings (with GitHub's anchors),
    paragraphs, ``-`` lists, pipe tables (in a block that scrolls sideways on a narrow screen),
    fenced code, inline code, images, links and bold, and the folding GitHub also renders: a line
    ``<details>``, ``<summary>text</summary>`` or ``</details>`` passes through as HTML."""
    lines = text.split("\n")
    out, i = [], 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            out.append("<pre>" + html.escape("\n".join(lines[i + 1:j])) + "</pre>")
            i = j + 1
        elif line.strip() in ("<details>", "</details>"):
            out.append(line.strip())
            i += 1
        elif m := re.fullmatch(r"\s*<summary>(.*)</summary>\s*", line):
            out.append(f"<summary>{inline(m.group(1))}</summary>")
            i += 1
        elif m := re.match(r"(#{1,6}) (.*)", line):
            level, title = len(m.group(1)), m.group(2)
            out.append(f'<h{level} id="{slug(title)}">{inline(title)}</h{level}>')
            i += 1
        elif line.startswith("|") and i + 1 < len(lines) and re.match(r"\|?\s*-{3,}", lines[i + 1]):
            head = "".join(f"<th>{inline(c)}</th>" for c in _cells(line))
            rows, i = [], i + 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append("<tr>" + "".join(f"<td>{inline(c)}</td>" for c in _cells(lines[i])) + "</tr>")
                i += 1
            out.append(f'<div class="scroll"><table><tr>{head}</tr>\n' + "\n".join(rows) + "</table></div>")
        elif line.startswith("- "):
            items = []
            while i < len(lines) and lines[i].startswith("- "):
                items.append(f"<li>{inline(lines[i][2:])}</li>")
                i += 1
            out.append("<ul>" + "".join(items) + "</ul>")
        elif not line.strip():
            i += 1
        else:
            para = []
            while i < len(lines) and lines[i].strip() and not re.match(r"(#{1,6} |```|\||- |\s*</?details>|\s*<summary>)",
                                                                           lines[i]):
                para.append(lines[i])
                i += 1
            out.append(f"<p>{inline(' '.join(para))}</p>")
    return "\n".join(out)
