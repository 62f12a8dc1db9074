"""The diff report: ``report.md``, ``report.json`` and a self-contained ``index.html``.

The HTML page needs no network: one ``index.html`` with its own CSS and a little JavaScript,
and beside it ``assets/`` with one PNG per image (at most :data:`SPRITE_MAX_SIDE` px) and one
SVG overlay per attachment and method (the artist's mesh green, the generated mesh orange,
exterior vertices blue, interior vertices yellow). The sprite sits on a checkerboard so that
transparent pixels show. A radio button picks the method shown in every overlay and in the
per-attachment table, whose columns sort on click; ``index.html#m=grid`` opens on one method.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import cv2
import numpy as np

from ..files.atomic import atomic_write_bytes, atomic_write_json, atomic_write_png, atomic_write_text
from ..files.strict_json import finite
from ..written_folder import check_written_folder, mark_written_folder, rewriting_folder
from ..mesher import Mesh
from .run import DiffResult

#: Longest side of a sprite PNG in the HTML assets (px); the SVG overlays stay exact.
SPRITE_MAX_SIDE = 384

#: Measures of the aggregate table: (key, heading, format). Means over all attachments.
COLUMNS = (
    ("vertices", "Vertices", "{:.1f}"),
    ("triangles", "Triangles", "{:.1f}"),
    ("coverage", "Coverage", "{:.1%}"),
    ("waste", "Waste", "{:.1%}"),
    ("boundary_adherence", "Boundary adherence", "{:.1%}"),
    ("angle_ratio", "Angle ratio", "{:.3f}"),
    ("hull_iou", "Hull IoU", "{:.3f}"),
    ("chamfer", "Chamfer (px)", "{:.2f}"),
)

#: What each method is, for the tables' first column.
METHOD_LABELS = {
    "artist": "Artist (reference)",
    "default": "spinemesh default preset",
    "paper": "spinemesh paper preset (sec. 3)",
    "hull": "Alpha-only hull (baseline)",
    "grid": "Uniform grid (baseline)",
    "shi-tomasi": "Shi-Tomasi corners (baseline)",
}

COLOURS = {"artist": "#1fbf3f", "ours": "#ff8c1a", "exterior": "#2f6bff", "interior": "#ffd21f"}


# --------------------------------------------------------------------------- tables
def aggregate(result: DiffResult) -> list[dict]:
    """One dict per method (artist first): ``method``, ``n``, ``failed`` and the mean of each
    measure of :data:`COLUMNS` over the attachments where the method produced a mesh."""
    out = []
    for method in ("artist",) + tuple(result.methods):
        ok = [r.metrics[method] for r in result.rows if "error" not in r.metrics.get(method, {"error": 1})]
        row = {"method": method, "n": len(ok), "failed": len(result.rows) - len(ok)}
        for key, _, _ in COLUMNS:
            vals = [m[key] for m in ok if key in m and np.isfinite(m[key])]
            row[key] = float(np.mean(vals)) if vals else None
        if method == "artist":
            row["hull_iou"], row["chamfer"] = None, None  # against itself: 1 and 0 by definition
        out.append(row)
    return out


def _fmt(value, fmt: str) -> str:
    return "-" if value is None else fmt.format(value)


def meshes_cell(a: dict) -> str:
    """The meshes a method made, and how many attachments it failed on (the page said ``122`` where
    the Markdown said ``122 (16 failed)``, so a reader of the page did not know of the failures)."""
    return str(a["n"]) + (f" ({a['failed']} failed)" if a["failed"] else "")


def aggregate_markdown(agg: list[dict]) -> str:
    """The aggregate table in Markdown (like the paper's comparison table, sec. 5)."""
    head = "| Method | Meshes | " + " | ".join(h for _, h, _ in COLUMNS) + " |"
    sep = "|---|---:|" + "---:|" * len(COLUMNS)
    lines = [head, sep]
    for a in agg:
        cells = [_fmt(a[k], f) for k, _, f in COLUMNS]
        lines.append(f"| {METHOD_LABELS.get(a['method'], a['method'])} | {meshes_cell(a)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def rows_markdown(result: DiffResult) -> str:
    """One row per attachment: artist counts, then per method vertices, Chamfer and IoU."""
    methods = result.methods
    head = ("| Project | Skeleton | Slot | Attachment | Size | Artist V/T | "
            + " | ".join(f"{m} V / Chamfer / IoU" for m in methods) + " |")
    lines = [head, "|---|---|---|---|---|---:|" + "---:|" * len(methods)]
    for r in result.rows:
        a = r.metrics["artist"]
        cells = []
        for m in methods:
            x = r.metrics[m]
            cells.append("failed (see Failed)" if "error" in x else f"{x['vertices']} / {x['chamfer']:.1f} / {x['hull_iou']:.2f}")
        lines.append(f"| {r.project} | {r.skeleton} | {r.slot} | {r.attachment} | {r.width}x{r.height} | "
                     f"{a['vertices']}/{a['triangles']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def failures_markdown(result: DiffResult) -> str:
    """Every method that failed on an attachment, with the reason (``""`` when none failed)."""
    lines = [f"- {r.project}/{r.skeleton} {r.slot}/{r.attachment}, {METHOD_LABELS.get(m, m)}: "
             f"{r.metrics[m]['error']}" for r in result.rows for m in result.methods
             if "error" in r.metrics.get(m, {})]
    return "".join(line + "\n" for line in lines)


def to_markdown(result: DiffResult, agg: list[dict] | None = None) -> str:
    """``report.md``: aggregate table, per-attachment table, skipped attachments."""
    agg = aggregate(result) if agg is None else agg
    parts = [
        "# spinemesh diff: generated meshes against the artists' meshes\n",
        f"{len(result.rows)} artist mesh attachments; means over attachments. Coverage: art pixels "
        "(alpha >= 8) entirely inside the mesh; waste: transparent share of the mesh area; boundary "
        "adherence: significant internal edge pixels with a vertex within 10 px; angle ratio: mean "
        "smallest/largest angle per triangle; hull IoU: covered area against the artist's; Chamfer: "
        "mean of both directed mean nearest-vertex distances to the artist's vertices (px).\n",
        aggregate_markdown(agg),
        "\n## Per attachment\n",
        rows_markdown(result),
    ]
    failures = failures_markdown(result)
    if failures:
        parts += ["\n## Failed\n", failures]
    if result.skipped:
        parts.append("\n## Skipped\n")
        parts += [f"- {s['project']}/{s['skeleton']} {s['slot']}/{s['attachment']}: {s['reason']}\n"
                  for s in result.skipped]
    return "\n".join(parts)


def _rows_json(result: DiffResult) -> list[dict]:
    """The rows as the report writes them, each image file named from its project folder's name
    (``meshed/images/demo-body.png``): the absolute path of this machine was written, the same
    report differing from one folder or machine to the next."""
    from ..files.names import named_within

    rows = [r.to_json() for r in result.rows]
    for folder in result.given:
        rows = named_within(rows, folder)
    return rows


def to_json(result: DiffResult, agg: list[dict] | None = None) -> dict:
    """``report.json``: ``methods``, ``aggregate``, ``rows``, ``skipped`` (no NaN or Infinity)."""
    agg = aggregate(result) if agg is None else agg
    return finite({"methods": list(result.methods), "aggregate": agg, "rows": _rows_json(result),
                   "skipped": result.skipped})


# --------------------------------------------------------------------------- SVG
def _viewbox(meshes: list[Mesh], w: int, h: int) -> tuple[float, float, float, float]:
    """A box holding the image and every mesh, with a small margin: (x, y, width, height)."""
    pts = np.vstack([m.vertices for m in meshes] + [np.array([[0.0, 0.0], [w, h]])])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.02 * float(max(hi - lo))
    return lo[0] - pad, lo[1] - pad, hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad


def _edges_path(mesh: Mesh) -> str:
    """SVG path data drawing each triangle edge once."""
    t = np.asarray(mesh.triangles, dtype=np.int64)
    if len(t) == 0:
        return ""
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    v = np.round(mesh.vertices, 1)
    return "".join(f"M{v[i, 0]:g} {v[i, 1]:g}L{v[j, 0]:g} {v[j, 1]:g}" for i, j in e)


def overlay_svg(artist: Mesh | None, mesh: Mesh | None, box: tuple[float, float, float, float]) -> str:
    """An SVG with the artist's wireframe (green) and/or ``mesh`` (orange, blue/yellow vertices).

    The page shows the two side by side, each on its own copy of the sprite, so that dense
    meshes stay readable. Strokes do not scale with the view, so lines stay one screen pixel
    wide at any size.
    """
    x, y, w, h = box
    r = max(w, h) / 80.0  # ~4 screen px on the 320 px stage
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x:g} {y:g} {w:g} {h:g}" '
             f'preserveAspectRatio="xMidYMid meet">']
    if artist is not None:
        parts.append(f'<path d="{_edges_path(artist)}" fill="none" stroke="{COLOURS["artist"]}" stroke-width="1.5" '
                     'vector-effect="non-scaling-stroke" stroke-opacity="0.9"/>')
    if mesh is not None:
        # dots shrink on dense meshes so that neighbouring vertices stay apart
        t = np.asarray(mesh.triangles, dtype=np.int64).reshape(-1, 3)
        if len(t):
            v = np.asarray(mesh.vertices, float)
            r = min(r, 0.3 * float(np.median(np.linalg.norm(v[t[:, 0]] - v[t[:, 1]], axis=1))))
        parts.append(f'<path d="{_edges_path(mesh)}" fill="none" stroke="{COLOURS["ours"]}" stroke-width="1.2" '
                     'vector-effect="non-scaling-stroke"/>')
        interior = np.asarray(mesh.is_interior, dtype=bool)
        for flag, colour in ((False, COLOURS["exterior"]), (True, COLOURS["interior"])):
            pts = np.round(mesh.vertices[interior == flag], 1)
            circles = "".join(f'<circle cx="{px:g}" cy="{py:g}" r="{r:.2f}"/>' for px, py in pts)
            parts.append(f'<g fill="{colour}" stroke="#000" stroke-width="1" '
                         f'vector-effect="non-scaling-stroke">{circles}</g>')
    parts.append("</svg>\n")
    return "".join(parts)


def _sprite_png(rgba: np.ndarray) -> np.ndarray:
    h, w = rgba.shape[:2]
    s = SPRITE_MAX_SIDE / max(h, w)
    if s >= 1:
        return rgba
    return cv2.resize(rgba, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)


# --------------------------------------------------------------------------- HTML
_CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222;background:#fafafa}
table{border-collapse:collapse;margin:.5em 0 1.5em}
th,td{border:1px solid #ccc;padding:3px 7px;text-align:right}
th{background:#eee;cursor:pointer;user-select:none}
td:first-child,th:first-child{text-align:left}
td.l{text-align:left}
.legend span{display:inline-block;width:12px;height:12px;margin:0 4px 0 12px;vertical-align:middle;border:1px solid #000}
.cards{display:flex;flex-wrap:wrap;gap:12px}
.card{background:#fff;border:1px solid #ccc;padding:6px;width:652px}
.pair{display:flex;gap:6px}
.pair figure{margin:0}
.pair figcaption{font-size:11px;color:#444}
.card h3{font-size:12px;margin:0 0 4px;word-break:break-all}
.stage{position:relative;width:320px;height:320px;
 background:repeating-conic-gradient(#ddd 0% 25%,#fff 0% 50%) 0 0/16px 16px}
.stage img{position:absolute;display:block}
.stage img.ov{left:0;top:0;width:100%;height:100%}
.card p{font-size:11px;margin:4px 0 0;color:#444}
"""

_JS = """
(function(){
  var data = JSON.parse(document.getElementById('rows').textContent);
  var cols = [['project','Project'],['skeleton','Skeleton'],['slot','Slot'],['attachment','Attachment'],
    ['a_vertices','Artist V'],['vertices','V'],['triangles','T'],['coverage','Coverage'],['waste','Waste'],
    ['boundary_adherence','Adherence'],['angle_ratio','Angle'],['hull_iou','Hull IoU'],['chamfer','Chamfer']];
  var method = data.methods[0], sortKey = null, sortDir = 1;
  function val(r, k){
    if (k === 'a_vertices') return r.metrics.artist.vertices;
    if (['project','skeleton','slot','attachment'].indexOf(k) >= 0) return r[k];
    var m = r.metrics[method]; return (m && k in m) ? m[k] : null;
  }
  // the same number formats as the summary table (data.formats comes from COLUMNS)
  function fmt(v, k){
    if (v === null) return 'failed';
    if (typeof v !== 'number') return String(v);
    var f = data.formats[k];
    if (!f || Number.isInteger(v)) return f && f[0] === 'pct' ? (v * 100).toFixed(f[1]) + '%' : String(v);
    return f[0] === 'pct' ? (v * 100).toFixed(f[1]) + '%' : v.toFixed(f[1]);
  }
  function render(){
    var idx = data.rows.map(function(_, i){ return i; });
    if (sortKey) idx.sort(function(a, b){
      var x = val(data.rows[a], sortKey), y = val(data.rows[b], sortKey);
      if (x === y) return 0; if (x === null) return 1; if (y === null) return -1;
      return (x < y ? -1 : 1) * sortDir; });
    var head = '<tr>' + cols.map(function(c){ return '<th data-k="' + c[0] + '">' + c[1] + '</th>'; }).join('') + '</tr>';
    var body = idx.map(function(i){ var r = data.rows[i];
      return '<tr>' + cols.map(function(c, j){ var v = val(r, c[0]);
        return j < 4 ? '<td class="l">' + (j === 3 ? '<a href="#a' + i + '">' : '') + String(v).replace(/&/g,'&amp;').replace(/</g,'&lt;') + (j === 3 ? '</a>' : '') + '</td>' : '<td>' + fmt(v, c[0]) + '</td>'; }).join('') + '</tr>'; }).join('');
    var t = document.getElementById('per');
    t.innerHTML = head + body;
    Array.prototype.forEach.call(t.querySelectorAll('th'), function(th){
      th.onclick = function(){ var k = th.getAttribute('data-k'); sortDir = (sortKey === k) ? -sortDir : 1; sortKey = k; render(); }; });
  }
  function show(m){
    method = m;
    Array.prototype.forEach.call(document.querySelectorAll('img.gen'), function(img){
      img.src = 'assets/' + img.getAttribute('data-i') + '-' + m + '.svg'; });
    Array.prototype.forEach.call(document.querySelectorAll('.card'), function(c){
      var r = data.rows[+c.getAttribute('data-i')], x = r.metrics[m];
      c.querySelector('figcaption.gen').textContent = m;
      c.querySelector('p').textContent = x && !('error' in x) ?
        'artist ' + r.metrics.artist.vertices + ' vertices, ' + m + ' ' + x.vertices + ' vertices; hull IoU ' +
        fmt(x.hull_iou, 'hull_iou') + ', Chamfer ' + fmt(x.chamfer, 'chamfer') + ' px, coverage ' + fmt(x.coverage, 'coverage')
        : m + ' failed: ' + ((x && x.error) || 'no mesh');
    });
    render();
  }
  // index.html#m=grid opens with that method shown
  var h = /m=([a-z-]+)/.exec(location.hash);
  if (h && data.methods.indexOf(h[1]) >= 0) method = h[1];
  Array.prototype.forEach.call(document.querySelectorAll('input[name=m]'), function(el){
    el.checked = (el.value === method);
    el.onchange = function(){ if (el.checked) show(el.value); }; });
  show(method);
})();
"""


def _js_formats() -> dict:
    """COLUMNS' formats for the page's script: ``{key: ["pct" | "fixed", digits]}``."""
    out = {}
    for key, _, fmt in COLUMNS:
        m = re.fullmatch(r"\{:\.(\d)([f%])\}", fmt)
        out[key] = ["pct" if m.group(2) == "%" else "fixed", int(m.group(1))]
    return out


def _aggregate_html(agg: list[dict]) -> str:
    head = "<tr><th>Method</th><th>Meshes</th>" + "".join(f"<th>{html.escape(h)}</th>" for _, h, _ in COLUMNS) + "</tr>"
    body = []
    for a in agg:
        cells = "".join(f"<td>{_fmt(a[k], f)}</td>" for k, _, f in COLUMNS)
        body.append(f"<tr><td>{html.escape(METHOD_LABELS.get(a['method'], a['method']))}</td><td>{meshes_cell(a)}</td>"
                    f"{cells}</tr>")
    return "<table>" + head + "".join(body) + "</table>"


#: Side of the square in which each mesh is drawn on the page (CSS px).
STAGE = 320


def _card(i: int, row, box) -> str:
    x, y, w, h = box
    s = STAGE / max(w, h)
    # the overlay SVG is centred in the square stage (xMidYMid meet): place the sprite to match
    ox, oy = (STAGE - w * s) / 2, (STAGE - h * s) / 2
    left, top = ox + (0 - x) * s, oy + (0 - y) * s
    title = html.escape(f"{row.project} / {row.skeleton} / {row.slot} / {row.attachment} ({row.width}x{row.height})")
    sprite = (f'<img src="assets/{i}.png" alt="" style="left:{left:.2f}px;top:{top:.2f}px;'
              f'width:{row.width * s:.2f}px;height:{row.height * s:.2f}px">')
    return (f'<div class="card" id="a{i}" data-i="{i}"><h3>{title}</h3><div class="pair">'
            f'<figure><div class="stage">{sprite}<img class="ov" alt="artist mesh" src="assets/{i}-artist.svg">'
            f'</div><figcaption>artist</figcaption></figure>'
            f'<figure><div class="stage">{sprite}<img class="ov gen" data-i="{i}" alt="generated mesh" src="">'
            f'</div><figcaption class="gen"></figcaption></figure></div><p></p></div>')


def to_html(result: DiffResult, agg: list[dict]) -> str:
    """``index.html`` (the assets are written by :func:`write_report`)."""
    boxes = [_viewbox(list(r.meshes.values()), r.width, r.height) for r in result.rows]
    radios = "".join(
        f'<label><input type="radio" name="m" value="{m}"{" checked" if k == 0 else ""}> '
        f'{html.escape(METHOD_LABELS.get(m, m))}</label> ' for k, m in enumerate(result.methods))
    legend = "".join(f'<span style="background:{COLOURS[k]}"></span>{label}' for k, label in (
        ("artist", "artist mesh"), ("ours", "generated mesh"), ("exterior", "exterior vertex"),
        ("interior", "interior vertex")))
    data = finite({"methods": list(result.methods), "rows": _rows_json(result),
                   "formats": _js_formats()})
    # "</" must not appear inside a <script> element
    data_json = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    cards = "".join(_card(i, r, b) for i, (r, b) in enumerate(zip(result.rows, boxes)))
    skipped = "".join(f"<li>{html.escape(s['project'] + '/' + s['skeleton'] + ' ' + s['slot'] + '/' + s['attachment'])}: "
                      f"{html.escape(s['reason'])}</li>" for s in result.skipped)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>spinemesh diff</title>
<link rel="icon" href="data:,">
<style>{_CSS}</style></head><body>
<h1>spinemesh diff: generated meshes against the artists' meshes</h1>
<p>{len(result.rows)} artist mesh attachments. Means over the attachments each method meshed.</p>
{_aggregate_html(agg)}
{"<p>Where a method failed, the attachment's card says why when that method is shown; report.md lists them all.</p>"
 if any(a["failed"] for a in agg) else ""}
<p>Show: {radios}</p>
<p class="legend">{legend}</p>
<h2>Per attachment</h2>
<p>Click a heading to sort; click an attachment to see its mesh.</p>
<table id="per"></table>
<h2>Meshes</h2>
<div class="cards">{cards}</div>
{"<h2>Skipped</h2><ul>" + skipped + "</ul>" if skipped else ""}
<script type="application/json" id="rows">{data_json}</script>
<script>{_JS}</script>
</body></html>
"""


#: What the refusal of a folder of someone else's files calls ``--out``.
REPORT_FOLDER = "report folder"


def write_report(result: DiffResult, out: str | Path) -> dict[str, Path]:
    """Write ``report.md``, ``report.json``, ``index.html`` and ``assets/`` into folder ``out``.

    A folder that holds files but no spinemesh report is refused (its files would be replaced,
    :func:`~spinemesh.written_folder.check_written_folder`); the folder written is marked as ours, so a
    later report is written into it again, and the earlier report's files (``assets/``) this one
    does not write again are removed then, with a killed run's temporary files
    (:func:`~spinemesh.written_folder.rewriting_folder`), never a file spinemesh did not write.

    Returns
    -------
    dict
        ``{"markdown", "json", "html"}`` -> written path.

    Raises
    ------
    OutputError
        For a folder of someone else's files, before anything is written.
    """
    out = Path(out)
    check_written_folder(out, REPORT_FOLDER, "report")
    with rewriting_folder(out):  # an earlier report's files not written again removed, as a killed run's
        return _write_files(result, out)


def _write_files(result: DiffResult, out: Path) -> dict[str, Path]:
    """:func:`write_report`'s files, written into ``out`` once it is checked."""
    mark_written_folder(out)  # before its first file: a report cut short is still ours to write again
    (out / "assets").mkdir(parents=True, exist_ok=True)
    agg = aggregate(result)
    for i, r in enumerate(result.rows):
        box = _viewbox(list(r.meshes.values()), r.width, r.height)
        atomic_write_png(out / "assets" / f"{i}.png", np.ascontiguousarray(_sprite_png(r.rgba)))
        for m in ("artist",) + tuple(result.methods):
            svg = overlay_svg(r.meshes["artist"], None, box) if m == "artist" else overlay_svg(None, r.meshes.get(m), box)
            atomic_write_bytes(out / "assets" / f"{i}-{m}.svg", svg.encode("utf-8"))
    paths = {"markdown": out / "report.md", "json": out / "report.json", "html": out / "index.html"}
    atomic_write_text(paths["markdown"], to_markdown(result, agg))
    atomic_write_json(paths["json"], to_json(result, agg))  # finite(): strict JSON
    atomic_write_text(paths["html"], to_html(result, agg))
    return paths
