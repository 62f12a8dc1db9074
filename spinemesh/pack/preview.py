"""``pack --preview DIR``: one HTML page with every packed page before and after.

Per atlas: its pages as exported and as packed, side by side at one scale (so sizes compare
at a glance), on a checkerboard (transparent texels show as such), with their sizes and
texel counts; then the regions that kept their rectangles and why. The pictures are PNG files
beside the page (``DIR/img/<content hash>.png``, as the upgrade's preview writes them:
:class:`spinemesh.player.PreviewFolder`), loaded when scrolled to, so that the page stays
small however many pages a project has; no script.
"""

from __future__ import annotations

import html
from collections import Counter
from pathlib import Path

import numpy as np

from ..images.texels import fit_within
from ..player import PreviewFolder
from ..player.files import html_page
from ..words import counted

#: Largest side, in pixels, of the largest page of an atlas in the picture.
PAGE_SIZE = 640

_CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:24px;color:#222}
.pages{display:flex;gap:24px;flex-wrap:wrap;align-items:flex-start}
figure{margin:0}
figcaption{font-size:12px;color:#555}
img{background:repeating-conic-gradient(#ddd 0 25%,#fff 0 50%) 0 0/16px 16px;border:1px solid #999;
image-rendering:pixelated}
table{border-collapse:collapse;display:block;max-width:100%;overflow-x:auto}
td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}td:first-child,th.text{text-align:left}
img{max-width:100%;height:auto}
@media (max-width:600px){body{margin:8px}.pages{gap:12px}}
"""


def _figure(folder: PreviewFolder, name: str, rgba: np.ndarray, scale: float) -> str:
    h, w = rgba.shape[:2]
    shown = fit_within(rgba, max(1, round(max(h, w) * scale)))
    src = html.escape(folder.image(shown, max(shown.shape[:2])))
    return (f'<figure><img loading="lazy" src="{src}" width="{shown.shape[1]}" height="{shown.shape[0]}" '
            f'alt="{html.escape(name)}"><figcaption>{html.escape(name)}: {w} x {h} = {w * h:,} texels'
            f'</figcaption></figure>')


def atlas_section(folder: PreviewFolder, rel: str, before: dict[str, np.ndarray], after: dict[str, np.ndarray],
                  row) -> str:
    """HTML of one atlas: its pages before and after at one scale (written under ``folder``),
    and its rectangle reasons."""
    largest = max(max(p.shape[:2]) for p in list(before.values()) + list(after.values()))
    scale = min(1.0, PAGE_SIZE / largest)
    reasons = Counter(r["reason"].split(" (")[0] for r in row.regions_by_rectangle)
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v}</td></tr>"
                   for k, v in reasons.most_common())
    return (f"<h2>{html.escape(rel)}</h2>"
            f"<p>page texels {row.texels_before:,} → {row.texels_after:,} "
            f"({row.texels_after / row.texels_before - 1:+.1%}), bytes {row.bytes_before:,} → {row.bytes_after:,}; "
            f"{counted(row.by_outline, 'region')} by outline, {row.by_rectangle} by rectangle, padding {row.padding}</p>"
            f"<h3>before</h3><div class=\"pages\">{''.join(_figure(folder, n, p, scale) for n, p in before.items())}</div>"
            f"<h3>after</h3><div class=\"pages\">{''.join(_figure(folder, n, p, scale) for n, p in after.items())}</div>"
            + (f"<h3>kept by rectangle</h3><table><tr><th class=\"text\">reason</th><th>regions</th></tr>{rows}</table>"
               if rows else ""))


def write_preview(result, folder: str | Path, project: str | Path | None = None) -> Path:
    """Write ``folder/index.html`` and its pictures (``folder/img/``) for a pack run (one made
    with ``keep_previews``), the files of ``project`` (the folder packed) named from its name;
    return the page's path."""
    files = PreviewFolder(folder, project)
    rows = {a.atlas: a for a in result.atlases}
    sections = [atlas_section(files, rel, before, after, rows[rel]) for rel, before, after in result.previews]
    kept = [a for a in result.atlases if a.status != "packed"]
    if kept:
        sections.append("<h2>atlases that kept their layout</h2><table><tr><th class=\"text\">atlas</th>"
                        "<th class=\"text\">why</th></tr>" + "".join(
            f"<tr><td>{html.escape(a.atlas)}</td><td style=\"text-align:left\">"
            f"{html.escape(a.reason)}</td></tr>" for a in kept) + "</table>")
    t = result.totals()
    summary = (f"<p>{counted(len(result.atlases), 'atlas', 'atlases')}; page texels {t['texels_before']:,} → {t['texels_after']:,}; "
               f"pages {t['pages_before']} → {t['pages_after']}; bytes {t['bytes_before']:,} → "
               f"{t['bytes_after']:,}</p>")
    page = html_page("spinemesh pack", _CSS, f"<h1>spinemesh pack</h1>{summary}{''.join(sections)}")
    files.write_text("index.html", page)
    files.finish()
    return files.root / "index.html"
