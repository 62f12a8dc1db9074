"""``upgrade --preview DIR``: pages that show what an upgrade changed, light at any size.

``DIR/index.html`` has the project's (or library's) **fill rate**, texels drawn before
(each region draws the rectangle its atlas stores) and after (the mesh) first, how many of
them were fully transparent second (transparent texels cost the GPU as much as visible ones),
one row per skeleton linking to its page, and, when the atlases were packed anew, every
atlas page before and after. ``DIR/s/<skeleton>.html``, one per skeleton: the original and
upgraded skeleton side by side in the player (:mod:`spinemesh.player`), and per upgraded
image the sprite with the old quad (dashed) and the new mesh, its counts and the transparent
area no longer drawn (or, for a mesh made to bend, that it was).

Images are PNG files under ``DIR/img`` (named by content, written once, loaded when scrolled
to), never inlined; the player's data are scripts under ``DIR/data``. A ``.json`` and its
``.skel`` twin are one skeleton (:func:`twin_of`): shown and counted once.

Counts are texels of the image as the atlas stores it (a page exported at scale 0.5 has a
quarter of the texels); each upgraded attachment counts once.
"""

from __future__ import annotations

import html
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import OutputError, SpineMeshError
from ..files.disk import file_stamp
from ..files.names import name_apart, safe_name
from ..player import PLAYER_CSS, PreviewFolder
from ..player.files import html_page
from ..player.frames import pose_skins  # noqa: F401  (the setup pose's skins, here since the page began)
from ..project import find_project, image_source_for
from ..skeleton import is_binary_skeleton, iter_skins, load_skeleton
from ..words import counted

#: Largest side of a sprite picture and of an atlas page picture, pixels.
CARD_SIZE = 300
PAGE_SIZE = 640
#: Most images shown per skeleton (largest saving first), so that the page stays light.
CARD_LIMIT = 200
#: What keeps a skeleton's player off its page (the page itself is still written).
_PLAYER_ERRORS = (SpineMeshError, KeyError, ValueError, TypeError, IndexError)


def _player_failure(error: BaseException) -> str | None:
    """Why the player of a skeleton (or some of its animations) could not be made, in words, when
    ``error`` costs that player alone (:data:`_PLAYER_ERRORS`, or memory refused while it was
    sampled, here or on a worker); None for an error that ends the preview."""
    from ..memory import out_of_memory

    if out_of_memory(error):
        detail = "" if isinstance(error, MemoryError) else f" ({error})"  # a library's own words
        return f"not enough memory to sample its poses{detail}"
    return str(error) if isinstance(error, _PLAYER_ERRORS) else None


@dataclass
class FillRate:
    """Texels drawn for one attachment before (its stored quad) and after (its mesh)."""

    before: int
    after: int
    transparent_before: int
    transparent_after: int

    def __add__(self, other: "FillRate") -> "FillRate":
        return FillRate(self.before + other.before, self.after + other.after,
                        self.transparent_before + other.transparent_before,
                        self.transparent_after + other.transparent_after)


def mesh_raster(uvs: np.ndarray, triangles: np.ndarray, width: int, height: int) -> np.ndarray:
    """Texels whose centre a mesh covers (edges included), shape (height, width), bool.

    Parameters
    ----------
    uvs : ndarray, shape (N, 2)
        Vertex UVs, 0..1 over the image.
    triangles : ndarray, shape (M, 3)
    """
    pts = np.asarray(uvs, float) * (width, height)
    out = np.zeros((height, width), bool)
    for tri in np.asarray(triangles, int).reshape(-1, 3):
        a, b, c = pts[tri]
        x0, y0 = np.floor(np.minimum(np.minimum(a, b), c)).astype(int).clip(0, (width, height))
        x1, y1 = np.ceil(np.maximum(np.maximum(a, b), c)).astype(int).clip(0, (width, height))
        if x1 <= x0 or y1 <= y0:
            continue
        cx, cy = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)

        def side(p, q):  # signed area of (p, q, centre): which side of edge p->q each centre lies on
            return (q[0] - p[0]) * (cy - p[1]) - (q[1] - p[1]) * (cx - p[0])

        s1, s2, s3 = side(a, b), side(b, c), side(c, a)
        inside = ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
        out[y0:y1, x0:x1] |= inside
    return out


def fill_rate(rgba: np.ndarray, box: tuple[int, int, int, int], uvs: np.ndarray,
              triangles: np.ndarray) -> FillRate:
    """Texels drawn by a region (its stored ``box``) and by the mesh that replaced it.

    A texel is transparent when its alpha is 0: drawing it changes nothing on screen.
    """
    h, w = rgba.shape[:2]
    x0, y0, x1, y1 = box
    quad = np.zeros((h, w), bool)
    quad[y0:y1, x0:x1] = True
    mesh = mesh_raster(uvs, triangles, w, h) & quad  # the mesh never draws outside what is stored
    clear = rgba[..., 3] == 0
    return FillRate(int(quad.sum()), int(mesh.sum()), int((quad & clear).sum()), int((mesh & clear).sum()))


def _find(doc: dict, skin: str, slot: str, name: str) -> dict | None:
    for s, slots in iter_skins(doc):
        if s == skin and isinstance(slots.get(slot), dict):
            att = slots[slot].get(name)
            return att if isinstance(att, dict) else None
    return None


def _mesh_arrays(att: dict) -> tuple[np.ndarray, np.ndarray, int]:
    uvs = np.asarray(att.get("uvs", []), float).reshape(-1, 2)
    tris = np.asarray(att.get("triangles", []), int).reshape(-1, 3)
    return uvs, tris, int(att.get("hull", 0))


def _mesh_svg(uvs: np.ndarray, tris: np.ndarray, hull: int, to_xy, stroke: float) -> str:
    """SVG of a mesh: triangle edges, the hull loop thicker."""
    pts = to_xy(uvs)
    edges = {tuple(sorted((int(a), int(b)))) for t in tris for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    d = "".join(f"M{pts[a, 0]:.1f} {pts[a, 1]:.1f}L{pts[b, 0]:.1f} {pts[b, 1]:.1f}" for a, b in sorted(edges))
    out = f'<path d="{d}" class="tri" stroke-width="{stroke:.2f}"/>'
    if hull >= 3:
        loop = " ".join(f"{x:.1f},{y:.1f}" for x, y in pts[:hull])
        out += f'<polygon points="{loop}" class="hull" stroke-width="{1.8 * stroke:.2f}"/>'
    return out


# --- the page ------------------------------------------------------------------------------

_CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:24px;color:#222;background:#fff}
h1{font-size:22px;overflow-wrap:anywhere}h2{font-size:18px;margin-top:32px}
table.sum{border-collapse:collapse;display:block;max-width:100%;overflow-x:auto}table.sum td,table.sum th{padding:3px 10px;border-bottom:1px solid #ddd;text-align:right}
table.sum td:first-child,table.sum th:first-child{text-align:left}table.sum td:first-child{overflow-wrap:anywhere;min-width:12em}
.big{font-size:20px;font-weight:600;color:#146c2e;margin:4px 0}.second{font-size:16px;color:#333;margin:2px 0 12px}
.cards{display:flex;flex-wrap:wrap;gap:14px}
.card{border:1px solid #ccc;border-radius:6px;padding:8px;width:300px}
.card .pic{position:relative;margin:auto;image-rendering:pixelated}
.card .pic img,.card .pic svg{position:absolute;left:0;top:0}
.card .name{font-weight:600;word-break:break-all}.card .who{color:#666;font-size:12px;word-break:break-all}
.card td{padding:1px 6px}.card td:nth-child(2),.card td:nth-child(3){text-align:right}
svg .tri{fill:none;stroke:#e0582b;stroke-opacity:.9}svg .hull{fill:none;stroke:#1f5fd1}
svg .quad{fill:none;stroke:#c00;stroke-dasharray:5 4}
.note{color:#555;font-size:12px;margin-top:4px}.bent img{max-width:100%;margin-top:6px}
.legend span{display:inline-block;margin-right:18px}.legend i{display:inline-block;width:22px;height:0;vertical-align:middle;margin-right:6px}
.pages{display:flex;gap:24px;flex-wrap:wrap;align-items:flex-start}figure{margin:0}
figcaption{font-size:12px;color:#555}.pages img{border:1px solid #999;image-rendering:pixelated}
""" + PLAYER_CSS

_LEGEND = ('<p class="legend"><span><i style="border-top:3px dashed #c00"></i>old quad (what the region drew)</span>'
           '<span><i style="border-top:3px solid #1f5fd1"></i>new mesh hull</span>'
           '<span><i style="border-top:2px solid #e0582b"></i>new mesh triangles</span></p>')


def _pct(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f}%" if whole else "-"


def _less(part: int, whole: int) -> str:
    """``part`` fewer out of ``whole`` as a change ("−20.1%"), or "-" when there is no whole."""
    return f"−{_pct(part, whole)}" if whole else "-"


def _card(folder: PreviewFolder, up: str, rgba: np.ndarray, box, att: dict, names: list[str], rate: FillRate,
          frames: int = 1, bent: np.ndarray | None = None, bends: str = "") -> str:
    """One upgraded image: the sprite with the old quad and the new mesh, its counts and saving.

    Images are files beside the pages (``up`` leads from the page to the preview folder),
    loaded when scrolled to. ``frames`` > 1: the image is the first frame of a sequence whose
    one mesh covers every frame's art; ``bent``: the weights picture of the mesh (setup pose
    coloured by bone, one bent pose); ``bends``: the mesh was made to bend over its bones, the
    keep rule alone would have kept the region (this reason), so its saving is not why it exists.
    """
    uvs, tris, hull = _mesh_arrays(att)
    h, w = rgba.shape[:2]
    pic = folder.image(rgba, CARD_SIZE - 20)
    k = min((CARD_SIZE - 20) / max(w, h), 4.0)  # small sprites are shown up to 4x, texels kept square
    pw, ph = max(1, round(w * k)), max(1, round(h * k))
    x0, y0, x1, y1 = box
    stroke = 1.0 / k
    svg = (f'<svg viewBox="0 0 {w} {h}" width="{pw}" height="{ph}">'
           f'<rect x="{x0}" y="{y0}" width="{x1 - x0}" height="{y1 - y0}" class="quad" stroke-width="{1.5 * stroke:.2f}"/>'
           + _mesh_svg(uvs, tris, hull, lambda uv: uv * (w, h), stroke) + "</svg>")
    saved = rate.transparent_before - rate.transparent_after
    rows = [("vertices", "4", str(len(uvs))), ("triangles", "2", str(len(tris))),
            ("texels drawn", f"{rate.before:,}", f"{rate.after:,}"),
            ("of them transparent", f"{rate.transparent_before:,}", f"{rate.transparent_after:,}")]
    table = "<table><tr><td></td><td>region</td><td>mesh</td></tr>" + "".join(
        f"<tr><td>{a}</td><td>{b}</td><td>{c}</td></tr>" for a, b, c in rows) + "</table>"
    who = html.escape(", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else ""))
    why = (f'<div><b>Made to bend</b> over its bones: as a region it would have been kept '
           f'({html.escape(bends)}); what it draws is not why it exists.</div>' if bends else
           f'<div>transparent area no longer drawn: <b>{saved:,}</b> texels '
           f'({_pct(saved, rate.transparent_before)} of it)</div>')
    return (f'<div class="card"><div class="name">{html.escape(att.get("path") or names[0].rsplit("/", 1)[-1])}</div>'
            f'<div class="who">{who}</div>'
            f'<div class="pic checker" style="width:{pw}px;height:{ph}px"><img loading="lazy" src="{up}{pic}" '
            f'width="{pw}" height="{ph}" alt="">{svg}</div>{table}{why}'
            + (f'<div class="note">One mesh for the {frames} frames of this sequence: it covers the art of '
               'every frame, so it reaches beyond the art of the frame shown.</div>' if frames > 1 else "")
            + (f'<div class="note bent">Bound to its bones (--weights auto): vertices coloured by bone, and '
               f'the mesh with its bones turned:<img loading="lazy" src="{up}{folder.image(bent, 800)}" '
               'alt="bent pose"></div>' if bent is not None else "")
            + '</div>')


def _reasons_table(result, targets=None) -> str:
    """Why attachments were kept as regions or failed, with counts, most frequent first.

    Reasons worded alike are one row whatever their figures ("the art fills 98% ..." and
    "... 92% ..."), with the most frequent as the example (:func:`spinemesh.runs.reason_groups`);
    reasons worded differently are never folded together. ``targets``: these only (default all).
    """
    from ..runs import reason_groups

    targets = result.targets if targets is None else targets
    rows = "".join(
        f"<tr><td>{html.escape(status)}</td><td style=\"text-align:left\">{html.escape(example)}"
        + (f" <i>({others:,} of them with other figures)</i>" if others else "")
        + f"</td><td>{n:,}</td></tr>"
        for status in ("kept", "failed")
        for example, n, others in reason_groups([t.reason for t in targets if t.status == status]))
    if not rows:
        return ""
    # under its own heading: right after the skeletons' table it read as more rows of it
    return ('<h2>Why regions were left as they are</h2><table class="sum"><tr><th>left a region</th>'
            f'<th style="text-align:left">why (an example)</th><th>attachments</th></tr>{rows}</table>')


class _ImageCache:
    """An image source that decodes each atlas page once per page (not once per lookup) and
    keeps each image it was asked for: the player and the cards ask for the same images, in
    orders that would make a two-page cache decode pages again and again."""

    def __init__(self, source):
        from ..images.sources import AtlasImages

        if isinstance(source, AtlasImages):
            pages = sum(len(a.pages) for a in source.atlases)
            source = AtlasImages(source.atlases, source.root, cache_pages=min(pages, 8))
        self.source = source
        self.images: dict = {}

    def get(self, name: str):
        if name not in self.images:
            self.images[name] = self.source.get(name)
        return self.images[name]

    def rgba_and_content(self, name: str):
        """``(rgba, content box)`` of an image, or None when it cannot be read."""

        try:
            image = self.get(name)
        except SpineMeshError:
            return None
        return image.rgba, image.content


# --- which skeletons, where -----------------------------------------------------------------

@dataclass
class _Skeleton:
    """One written skeleton: its path in the run, the original and upgraded files, its project."""

    rel: str
    original: Path
    upgraded: Path
    project: object
    twins: list[str] = field(default_factory=list)
    stamps: tuple = ()  # the files' stamps (files.disk.file_stamp) taken before they were read


def _skeletons(result, project: Path, out: Path, projects: list[Path] | None = None) -> list[_Skeleton]:
    """Every written skeleton with its original file and project (a library: each skeleton's own,
    among ``projects``, the library's projects, found when not given)."""
    from .library import library_projects

    if projects is None:
        projects = library_projects(project)
    roots = {Path(p).relative_to(project).as_posix(): Path(p) for p in projects} if projects is not None else None
    single = find_project(project) if roots is None else None
    cache: dict = {}
    out_list = []
    for rel in result.written:
        if roots is None:
            proj, original = single, single.root / rel
        else:
            root = max((r for r in roots if rel.startswith(r + "/") or r == "."), key=len, default=None)
            if root is None:
                continue
            if root not in cache:
                cache[root] = find_project(roots[root])
            proj = cache[root]
            original = project / rel
        out_list.append(_Skeleton(rel, original, out / rel, proj))
    return out_list


_STEM = re.compile(r"(\.json|\.skel|\.json\.txt|\.skel\.bytes|\.spine-json)$", re.I)
_BINARY = re.compile(r"(\.skel|\.skel\.bytes)$", re.I)


def skeleton_signature(doc: dict) -> str:
    """What makes two skeleton files one skeleton: bone names and parents, slot names and
    bones, every skin's attachment names, types and image paths, and animation names, as one
    text (numbers are left out: a JSON export rounds them, a binary one does not)."""
    bones = [(b.get("name"), b.get("parent")) for b in doc.get("bones", []) if isinstance(b, dict)]
    slots = [(s.get("name"), s.get("bone")) for s in doc.get("slots", []) if isinstance(s, dict)]
    atts = sorted((skin, slot, name, str(a.get("type", "region")), str(a.get("path", name)))
                  for skin, slots_ in iter_skins(doc) for slot, named in slots_.items() if isinstance(named, dict)
                  for name, a in named.items() if isinstance(a, dict))
    anims = sorted(doc.get("animations", {}) or {}) if isinstance(doc.get("animations"), dict) else []
    return repr((bones, slots, atts, anims))


def twin_of(rels: list[str], signatures: dict[str, str], binary: dict[str, bool] | None = None) -> dict[str, str]:
    """For each twin, the skeleton it repeats: ``{rel: first rel}``.

    Two files are twins (a ``.json`` and a ``.skel``, as the editor exports both) when they lie
    in one folder, one is JSON and the other binary, and they hold the same skeleton
    (:func:`skeleton_signature`: bones, slots, attachments with their image paths,
    animations). The first in ``rels`` order is kept; its twin is drawn and counted once,
    under it. ``binary``: whether each file is binary (default: by its name, ``.skel``).
    """
    binary = binary or {rel: bool(_BINARY.search(rel)) for rel in rels}
    first: dict[tuple[str, str], list[str]] = {}
    out = {}
    for rel in rels:
        if rel not in signatures:
            continue
        key = (rel.rsplit("/", 1)[0] if "/" in rel else "", signatures[rel])
        group = first.setdefault(key, [])
        partner = next((r for r in group if binary[r] != binary[rel] and r not in out.values()), None)
        if partner is not None:
            out[rel] = partner
        else:
            group.append(rel)
    return out


# --- a skeleton's page ----------------------------------------------------------------------

def _regions_of(source):
    """The atlases the player's region quads follow (:func:`spinemesh.anim.atlas_regions`), or None."""
    from ..images.sources import AtlasImages

    return source.source.atlases if source is not None and isinstance(source.source, AtlasImages) else None


def _player(folder: PreviewFolder, pid: str, page_rel: str, played: list, source) -> str:
    """The player of one skeleton: ``played``, its setup pose and every animation, both sides."""
    from ..player import write_player

    def image_of(path: str):
        got = source.rgba_and_content(path) if source is not None else None
        return None if got is None else got[0]

    return write_player(folder, pid, page_rel, played, image_of)


def _skeleton_page(folder: PreviewFolder, sk: _Skeleton, pid: str, targets: list, all_targets: list,
                   before: dict, after: dict, source, played) -> tuple[str, FillRate]:
    """Write one skeleton's page; return its path under the preview and its fill rate.
    ``played(problems)`` gives the player's animations (:func:`spinemesh.player.animations`)."""

    page_rel = f"s/{pid}.html"
    up = "../"
    cards, seen = [], {}
    for t in targets:
        seen.setdefault(t.key, []).append(t)
    rate_total = FillRate(0, 0, 0, 0)
    weighted = any(t.weights is not None for t in targets)
    rig = None
    for key, group in seen.items():
        t = group[0]
        att = _find(after, t.skin, t.slot, t.name)
        if att is None or source is None:
            continue
        got = source.rgba_and_content(t.paths[0])
        if got is None:
            continue
        rgba, box = got
        uvs, tris, _ = _mesh_arrays(att)
        rate = fill_rate(rgba, box, uvs, tris)
        for _ in group:  # every attachment drawing this image saves as much
            rate_total = rate_total + rate
        bent = None
        if weighted and len((t.weights or {}).get("bones") or {}) > 1 and t.weights.get("status") == "weighted":
            from ..rig.document import build_rig
            from ..rig.preview import weighted_picture

            rig = rig or build_rig(after)
            bent = weighted_picture(after, att, rig, rgba)
        bends = next((g.overruled for g in group if g.overruled), "")
        cards.append((rate.transparent_before - rate.transparent_after,
                      _card(folder, up, rgba, box, att, [f"{g.skin}/{g.slot}/{g.name}" for g in group], rate,
                            frames=len(t.paths), bent=bent, bends=bends)))
    cards.sort(key=lambda c: -c[0])
    more = len(cards) - CARD_LIMIT
    cards = cards[:CARD_LIMIT] + ([(0, f"<p>… and {more} more images with smaller savings (counted in the "
                                          "totals).</p>")] if more > 0 else [])
    twins = (f"<p>Also written as {html.escape(', '.join(sk.twins))}: the same skeleton, shown and counted "
             "once.</p>" if sk.twins else "")
    problems: list[str] = []
    try:
        player = _player(folder, pid, page_rel, played(problems), source)
    except OutputError:  # the disk refused the player's files: not a pose, and the next page would fail too
        raise
    except Exception as e:  # the rest of the page, and the other skeletons' pages, still help
        why = _player_failure(e)
        if why is None:
            raise
        player, problems = "", [f"the player could not pose this skeleton: {why}"]
    # the player first, under the title, where a window opens the page; the texel counts after it
    body = (f'<p><a href="../index.html">← all skeletons</a></p><h1>{html.escape(sk.rel)}: original and upgraded, '
            f'side by side</h1>{twins}'
            + player + ("<ul>" + "".join(f"<li>{html.escape(p)}</li>" for p in problems) + "</ul>" if problems else "")
            + ("<h2>Texels drawn</h2>" if rate_total.before else "")
            + _headline_html(rate_total, len(targets)) + _rate_table(rate_total)
            + "<h2>Upgraded images, largest saving first</h2>"
            + (f'{_LEGEND}<div class="cards">{"".join(c for _, c in cards)}</div>' if cards else
               "<p>No attachment of this skeleton became a mesh.</p>")
            + _reasons_table(None, all_targets))
    folder.write_text(page_rel, html_page(f"spinemesh upgrade: {sk.rel}", _CSS, body))
    return page_rel, rate_total


# --- the index ------------------------------------------------------------------------------

def _headline_html(total: FillRate, meshed: int) -> str:
    """Texels drawn before and after first, then the transparent ones among them."""
    if not total.before:
        return ""
    return (f'<p class="big">Texels drawn: {total.before:,} → {total.after:,} '
            f'({_less(total.before - total.after, total.before)})</p>'
            f'<p class="second">of them fully transparent: {total.transparent_before:,} → '
            f'{total.transparent_after:,} ({_less(total.transparent_before - total.transparent_after, total.transparent_before)})'
            f' over the {counted(meshed, "attachment")} meshed</p>')


def _rate_table(total: FillRate) -> str:
    if not total.before:
        return ""
    return ('<table class="sum"><tr><th></th><th>regions (before)</th><th>meshes (after)</th><th>change</th></tr>'
            f"<tr><td>texels drawn</td><td>{total.before:,}</td><td>{total.after:,}</td>"
            f"<td>{_less(total.before - total.after, total.before)}</td></tr>"
            f"<tr><td>of them fully transparent</td><td>{total.transparent_before:,}</td>"
            f"<td>{total.transparent_after:,}</td>"
            f"<td>{_less(total.transparent_before - total.transparent_after, total.transparent_before)}</td></tr></table>")


def _headline(result, total: FillRate) -> str:
    """The index's headline when no texel count leads it: what happened instead."""
    counts = result.counts()
    packed = [a for a in result.atlases if a.status == "packed"]
    if packed and not counts.get("meshed"):
        before, after = sum(a.texels_before for a in packed), sum(a.texels_after for a in packed)
        return (f"No attachment meshed; {counted(len(packed), 'atlas', 'atlases')} packed anew: page "
                f"texels {before:,} → {after:,} ({_less(before - after, before)}), see the pages below")
    if result.not_read and not counts.get("meshed"):
        n = len(result.not_read)
        return f"Nothing meshed: {counted(n, 'skeleton')} could not be read (see below)"
    if counts.get("failed") and not counts.get("meshed"):
        return f"Nothing meshed: {counted(counts['failed'], 'attachment')} failed (see why below)"
    if not result.targets:
        return "Nothing to upgrade: no region attachment (every attachment is already a mesh or of another type)"
    if counts.get("meshed"):
        return f"{counted(counts['meshed'], 'attachment')} meshed (their images could not be read for this page)"
    return "Nothing meshed: every region was kept as it is (see why below)"


def _problems(result) -> str:
    """The skeletons that could not be read and the other errors, one line each (or nothing)."""
    if not result.errors:
        return ""
    unread = set(result.not_read.values())
    items = [f"<li><b>not read:</b> {html.escape(e)}</li>" for e in result.not_read.values()]
    items += [f"<li>{html.escape(e)}</li>" for e in result.errors if e not in unread]
    return f"<h3>Problems</h3><ul>{''.join(items)}</ul>"


def _atlas_pages(folder: PreviewFolder, result, project_root: Path, out: Path) -> str:
    """Every packed atlas's pages before and after (files, loaded when scrolled to)."""
    from ..atlas import read_atlas
    from ..images.decode import load_rgba
    from ..images.sources import AtlasImages
    from ..images.texels import fit_within

    def figures(atlas_path: Path, root: Path) -> str:
        atlas = read_atlas(atlas_path, strict=False)
        out_html = []
        for page in atlas.pages:
            rgba = load_rgba(AtlasImages.page_path(atlas, page.name, root))
            h, w = rgba.shape[:2]
            shown = fit_within(rgba, PAGE_SIZE)
            rel = folder.image(shown, PAGE_SIZE)
            out_html.append(f'<figure><img class="checker" loading="lazy" src="{rel}" width="{shown.shape[1]}" '
                            f'height="{shown.shape[0]}" alt="{html.escape(page.name)}"><figcaption>'
                            f'{html.escape(page.name)}: {w} x {h} = {w * h:,} texels</figcaption></figure>')
        return "".join(out_html)

    parts = []
    for row in result.atlases:
        if row.status != "packed":
            continue
        try:
            before = figures(project_root / row.atlas, project_root)
            after = figures(out / row.atlas, out)
        except SpineMeshError as e:
            parts.append(f"<h3>{html.escape(row.atlas)}</h3><p>pages not shown: {html.escape(str(e))}</p>")
            continue
        parts.append(f"<h3>{html.escape(row.atlas)}</h3><p>page texels {row.texels_before:,} → {row.texels_after:,} "
                     f"({_less(row.texels_before - row.texels_after, row.texels_before)}), bytes "
                     f"{row.bytes_before:,} → {row.bytes_after:,}</p><h4>before</h4><div class=\"pages\">{before}</div>"
                     f"<h4>after</h4><div class=\"pages\">{after}</div>")
    kept = [a for a in result.atlases if a.status != "packed"]
    if kept:
        parts.append("<h3>atlases that kept their layout</h3><table class=\"sum\"><tr><th>atlas</th><th>why</th></tr>"
                     + "".join(f"<tr><td>{html.escape(a.atlas)}</td><td style=\"text-align:left\">"
                               f"{html.escape(a.reason)}</td></tr>" for a in kept) + "</table>")
    return "<h2>Atlas pages</h2>" + "".join(parts) if parts else ""


def _read_pairs(skeletons: list[_Skeleton]) -> tuple[dict, dict, dict]:
    """Both files of every skeleton (``{rel: (original, upgraded)}``), the problems of those
    that could not be read (``{rel: error}``), and the twins (:func:`twin_of`), each listed
    under the skeleton it repeats."""

    docs: dict[str, tuple[dict, dict]] = {}
    problems: dict[str, str] = {}
    for sk in skeletons:
        sk.stamps = (file_stamp(sk.original), file_stamp(sk.upgraded))  # a worker reading them checks them
        try:
            docs[sk.rel] = (load_skeleton(sk.original), load_skeleton(sk.upgraded))
        except SpineMeshError as e:
            problems[sk.rel] = str(e)
    twins = twin_of([sk.rel for sk in skeletons], {rel: skeleton_signature(d[1]) for rel, d in docs.items()},
                    {sk.rel: is_binary_skeleton(sk.original) for sk in skeletons})
    by_rel = {sk.rel: sk for sk in skeletons}
    for rel, first in twins.items():
        by_rel[first].twins.append(rel)
    return docs, problems, twins


def _index_row(sk: _Skeleton, link: str | None, rate: FillRate, counts: dict, problem: str | None) -> str:
    """One skeleton's row of the index: its link, counts and fill rate."""
    name = html.escape(sk.rel) + (f" <small>(+ {html.escape(', '.join(sk.twins))})</small>" if sk.twins else "")
    cell = f'<a href="{link}">{name}</a>' if link else name
    return (f"<tr><td>{cell}" + (f"<br><small>not shown: {html.escape(problem)}</small>" if problem else "")
            + f"</td><td>{counts['meshed']:,}</td><td>{counts['kept']:,}</td><td>{counts['failed']:,}</td>"
            f"<td>{rate.before:,} → {rate.after:,}</td><td>{_less(rate.before - rate.after, rate.before)}</td>"
            f"<td>{rate.transparent_before:,} → {rate.transparent_after:,}</td>"
            f"<td>{_less(rate.transparent_before - rate.transparent_after, rate.transparent_before)}</td></tr>")


@dataclass
class _Page:
    """One skeleton's page as it is being made: what it shows, and its player's animations
    being sampled (here, or as ``chunks`` of animations handed to worker processes)."""

    skeleton: _Skeleton
    pid: str
    meshed: list
    targets: list
    source: object = None
    problem: str | None = None       # why its images could not be read
    setup: object = None             # the player's setup pose (spinemesh.player.Animation)
    sampling: object = None          # spinemesh.player.frames.Sampling
    sides: dict | None = None        # the samplers, where sampled in this process
    chunks: list = field(default_factory=list)  # (names, future) of the animations sampled elsewhere
    failed: Exception | None = None  # why the player cannot be made
    setup_problems: list = field(default_factory=list)  # what its planning left out, and why


#: Seconds of animation a worker samples at least per task (fewer tasks than animations: each
#: task of a skeleton a worker has not posed yet reads it again).
CHUNK_SECONDS = 5.0


def _chunks(durations: dict[str, float], parts: int) -> list[list[str]]:
    """The animations split, in order, into at most ``parts`` runs of about equal seconds (each
    at least :data:`CHUNK_SECONDS` but the last).

    Examples
    --------
    >>> _chunks({"a": 4.0, "b": 4.0, "c": 1.0, "d": 7.0}, 2)
    [['a', 'b'], ['c', 'd']]
    """
    total = sum(d for d in durations.values() if np.isfinite(d))
    size = max(CHUNK_SECONDS, total / max(1, parts))
    out: list[list[str]] = [[]]
    filled = 0.0
    for name, seconds in durations.items():
        if out[-1] and filled >= size:
            out.append([])
            filled = 0.0
        out[-1].append(name)
        filled += seconds if np.isfinite(seconds) else 0.0
    return [c for c in out if c]


def _region_table(atlases, regions, docs) -> dict:
    """What a worker needs of the atlases to pose ``docs``: the geometry
    (:func:`spinemesh.anim.atlas_regions`) of every region an attachment of theirs can draw, by
    name, ``table.get`` answering as ``atlas_regions(atlases)`` does. A region is kept where its
    name is an attachment's path, name or key, or one of those followed by digits (a sequence's
    frames): a superset of what the sampler asks. Sent in place of the atlases, which were
    pickled for every task (an atlas of 99,000 regions made the preview over ``--jobs 2`` four
    times slower than one process). ``regions`` is ``atlas_regions(atlases)``, already made."""
    bases: set[str] = set()
    for doc in docs:
        for _, slots in iter_skins(doc):
            for attachments in slots.values():
                for key, att in attachments.items() if isinstance(attachments, dict) else ():
                    bases.add(str(key))
                    if isinstance(att, dict):
                        bases.update(str(att[k]) for k in ("name", "path") if att.get(k) is not None)
    table = {}
    for atlas in atlases:
        for region in atlas.regions:
            name = region.name
            stem = len(name.rstrip("0123456789"))
            if name not in table and any(name[:k] in bases for k in range(stem, len(name) + 1)):
                table[name] = regions(name)
    return table


_WORKER_SIDES: dict = {}


def _sample_in_worker(task: tuple) -> list:
    """:func:`spinemesh.player.frames.sample_and_encode` in a worker process: the skeletons
    read there (not sent), their samplers kept for the next run of the same skeleton's.

    Raises
    ------
    SpineMeshError
        When a file is not the one the page was planned from (``stamps``, taken before this
        process read it): changed or replaced since, its animations would mix two versions.
    """
    from ..player.frames import sample_and_encode, sides_of

    original, upgraded, stamps, table, sampling, names = task
    key = (str(original), str(upgraded), stamps, repr(sampling.skins))
    if key not in _WORKER_SIDES:
        _WORKER_SIDES.clear()  # one skeleton's samplers at a time
        regions = table.get if table is not None else None  # _region_table
        docs = load_skeleton(original), load_skeleton(upgraded)
        for path, stamp in zip((original, upgraded), stamps):
            if file_stamp(path) != stamp:  # read after its stamp: any change since shows
                raise SpineMeshError("changed on disk while the preview was written (its animations would mix "
                                     "two versions); write the preview again", path)
        _WORKER_SIDES[key] = sides_of(*docs, sampling.skins, regions)
    return sample_and_encode(_WORKER_SIDES[key], sampling, names)


def _start_page(page: _Page, before: dict, after: dict, images_in, workers) -> _Page:
    """Read a page's images and plan its player; with ``workers``, hand its animations out."""
    from ..anim import atlas_regions
    from ..player.frames import plan_sampling

    sk = page.skeleton
    try:
        source = image_source_for(before, sk.original, sk.project, images=images_in)
    except SpineMeshError as e:
        page.problem, source = str(e), None
    page.source = None if source is None else _ImageCache(source)
    atlases = _regions_of(page.source)
    regions = atlas_regions(atlases) if atlases else None
    problems: list[str] = []
    try:
        page.setup, page.sampling, sides = plan_sampling(before, after, regions, problems)
    except Exception as e:  # said on the page (_skeleton_page), or the preview ends there
        if _player_failure(e) is None:
            raise
        page.failed = e
        return page
    page.setup_problems = problems
    if workers is None:
        page.sides = sides
        return page
    table = _region_table(atlases, regions, (before, after)) if atlases else None
    # runs of a few seconds each (8 a worker): each worker reads the skeleton once whatever their
    # number, and the preview's bar moves as each run comes back
    for names in _chunks(page.sampling.durations, 8 * workers.slots):
        page.chunks.append((names, workers.submit(_sample_in_worker,
                                                  (sk.original, sk.upgraded, sk.stamps, table, page.sampling, names))))
    return page


def _finish_page(files: PreviewFolder, page: _Page, before: dict, after: dict,
                 on_animations=None) -> tuple[str, FillRate, str | None]:
    """Write a started page (:func:`_start_page`): its path, fill rate and problem.
    ``on_animations(n)``: told as each run of ``n`` animations of its player is sampled."""
    from ..player.frames import collect, sample_and_encode

    def sampled_here(n: int) -> None:
        if on_animations is not None:
            on_animations(n)

    def played(problems: list) -> list:
        if page.failed is not None:
            raise page.failed
        problems += page.setup_problems
        sampled = []
        if page.sides is not None:
            for name in page.sampling.durations:  # each alone, from its time 0: the same frames as in one call
                sampled += sample_and_encode(page.sides, page.sampling, [name])
                sampled_here(1)
        else:
            for names, future in page.chunks:
                try:
                    sampled += future.result()
                except Exception as e:  # a worker lost, a file changed, memory refused: those animations alone are left out
                    why = _player_failure(e)
                    if why is None:
                        raise
                    shown = ", ".join(map(repr, names[:5])) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
                    problems.append(f"animation{'s' if len(names) > 1 else ''} {shown} not shown: {why}")
                sampled_here(len(names))
        return [page.setup] + collect(sampled, problems)

    link, rate = _skeleton_page(files, page.skeleton, page.pid, page.meshed, page.targets, before, after,
                                page.source, played)
    return link, rate, page.problem


def _write_pages(files: PreviewFolder, pages: dict[str, _Page], docs: dict, images_in, jobs: int,
                 on_skeleton=None, on_animations=None) -> dict[str, tuple]:
    """Every skeleton's page, ``{rel: (path, fill rate, problem)}``. With ``jobs`` over 1, the
    players' animations are sampled by that many processes, in runs of a few seconds of
    animation, while this process writes the page before (the same files: each animation is
    sampled alone, from its time 0). ``on_skeleton()`` after each page; ``on_animations(n)`` as
    its animations are sampled, :func:`_animation_count` of them in all (fewer where a player
    fails: the rest are told with the page)."""
    from contextlib import nullcontext

    from ..cluster import open_workers

    done: dict[str, tuple] = {}

    def finish(page: _Page) -> None:
        told = [0]

        def sampled(n: int) -> None:
            told[0] += n
            if on_animations is not None:
                on_animations(n)

        done[page.skeleton.rel] = _finish_page(files, page, *docs[page.skeleton.rel], on_animations=sampled)
        left = _animation_count(docs[page.skeleton.rel][1]) - told[0]
        if on_animations is not None and left > 0:
            on_animations(left)
        if on_skeleton is not None:
            on_skeleton()

    started: list[_Page] = []
    with open_workers(jobs) if jobs > 1 and pages else nullcontext() as workers:
        for rel, page in pages.items():
            started.append(_start_page(page, *docs[rel], images_in, workers))
            if len(started) > 1:  # the next page's animations are sampled while this one is written
                finish(started.pop(0))
        for page in started:
            finish(page)
    return done


class _Steps:
    """The preview's steps told as they are done: ``on_progress(done, total)`` (from ``(0, total)``
    on), and ``on_skeleton()`` after each skeleton. Calling it tells ``n`` steps (animations)."""

    def __init__(self, total: int, on_progress=None, on_skeleton=None):
        self.done, self.total, self.on_progress, self.on_skeleton = 0, total, on_progress, on_skeleton
        self(0)

    def __call__(self, n: int = 1) -> None:
        self.done += n
        if self.on_progress is not None:
            self.on_progress(min(self.done, self.total), self.total)

    def skeleton(self) -> None:
        self(1)
        if self.on_skeleton is not None:
            self.on_skeleton()


def _animation_count(doc: dict) -> int:
    """How many animations a skeleton's player samples at most (:data:`~spinemesh.player.frames.MAX_ANIMATIONS`)."""
    from ..player.frames import MAX_ANIMATIONS

    anims = doc.get("animations") if isinstance(doc, dict) else None
    return min(len(anims), MAX_ANIMATIONS) if isinstance(anims, dict) else 0


def _pages_of(skeletons: list, twins, docs: dict, targets: dict[str, list]) -> dict[str, _Page]:
    """The page of each skeleton read and not a twin, by its path in the output, each named apart
    from the others on any disk (its page and data folder)."""
    pages: dict[str, _Page] = {}
    used_ids: set[str] = set()
    for sk in skeletons:
        if sk.rel in twins:
            continue
        mine = targets.get(sk.rel, [])
        # Hero.json and hero.json: one page and one data folder on a macOS or Windows disk
        pid = name_apart(safe_name(_STEM.sub("", sk.rel).replace("/", "__")), used_ids)
        if sk.rel in docs:
            pages[sk.rel] = _Page(sk, pid, [t for t in mine if t.status == "meshed"], mine)
    return pages


def _shown_name(path: Path) -> str:
    """A folder or file as the index names it: its own name (``.`` said by the folder's real name),
    never the path it was given by, which differs from one folder or machine to the next."""
    return Path(os.path.realpath(path)).name or str(path)


def write_preview(result, project: str | Path, out: str | Path, folder: str | Path,
                  images_in: str | Path | None = None, on_skeleton=None, jobs: int = 1, on_progress=None,
                  projects: list[Path] | None = None) -> Path:
    """Write the preview under ``folder`` (``index.html``, one page per skeleton, their images
    and player data) and return the index's path.

    Parameters
    ----------
    result : spinemesh.upgrade.report.Result
        What :func:`~spinemesh.upgrade.upgrade_project` or
        :func:`~spinemesh.upgrade.upgrade_library` returned.
    project : path
        The project (folder or skeleton file) or library that was upgraded: images are read from it.
    out : path
        The output folder the upgraded skeletons were written to.
    images_in : path, optional
        The ``--from-images`` folder, if the run used one.
    on_skeleton : callable, optional
        Called with no argument after each skeleton (for progress bars).
    jobs : int, default 1
        Processes sampling the players' animations (:func:`_write_pages`; the same files
        whatever the number).
    on_progress : callable, optional
        ``on_progress(done, total)`` as steps are done (:class:`_Steps`: each animation sampled, each skeleton).
    projects : list of path, optional
        A library's projects as the run found them (:func:`~spinemesh.upgrade.library_projects`);
        found again when not given.
    """
    project, out = Path(project), Path(out)
    files = PreviewFolder(folder, project if project.is_dir() else project.parent)
    skeletons = _skeletons(result, project, out, projects)
    docs, problems, twins = _read_pairs(skeletons)
    targets: dict[str, list] = {}
    for t in result.targets:
        targets.setdefault(t.skeleton, []).append(t)
    pages = _pages_of(skeletons, twins, docs, targets)
    told = _Steps(len(skeletons) + sum(_animation_count(docs[rel][1]) for rel in pages), on_progress, on_skeleton)
    done = _write_pages(files, pages, docs, images_in, jobs, told.skeleton, told)
    total, rows = FillRate(0, 0, 0, 0), []
    for sk in skeletons:
        if sk.rel not in pages:  # a twin, or a skeleton not read: no page
            told.skeleton()
            if sk.rel in twins:
                continue
        mine = targets.get(sk.rel, [])
        counts = {s: sum(t.status == s for t in mine) for s in ("meshed", "kept", "failed")}
        link, rate, problem = done.get(sk.rel, (None, FillRate(0, 0, 0, 0), None))
        if problem:
            problems[sk.rel] = problem
        total = total + rate
        rows.append(_index_row(sk, link, rate, counts, problems.get(sk.rel)))
    counts = {s: sum(t.status == s and t.skeleton not in twins for t in result.targets)
              for s in ("meshed", "kept", "failed")}
    headline = (_headline_html(total, counts.get("meshed", 0)) if total.before else
                f'<p class="big">{html.escape(_headline(result, total))}</p>')
    shown = len(skeletons) - len(twins)
    table = ('<table class="sum"><tr><th>skeleton</th><th>meshed</th><th>kept</th><th>failed</th>'
             '<th>texels drawn</th><th>change</th><th>transparent texels drawn</th><th>change</th></tr>'
             + "".join(rows) + "</table>")
    root = project if project.is_dir() else project.parent
    # names, not paths: the page's bytes stay the same from any folder, under any path (a build cache)
    body = (f"<h1>spinemesh upgrade: {html.escape(_shown_name(project))} → {html.escape(_shown_name(out))}</h1>"
            f"{headline}"
            + _rate_table(total)
            + f"<p>{counted(shown, 'skeleton')}" + (f" ({counted(len(twins), 'more file')} the same skeleton "
                                                    "in the other format, counted once)" if twins else "")
            + f"; attachments: {counts.get('meshed', 0)} meshed, "
            f"{counted(counts.get('kept', 0), 'kept as a region', 'kept as regions')}, "
            f"{counts.get('failed', 0)} failed. Each upgraded attachment counts once, in texels of its atlas "
            "image; a region draws the rectangle its atlas stores, a mesh only its triangles.</p>"
            + f"<h2>Skeletons</h2>{table}"
            + _atlas_pages(files, result, root, out)
            + _reasons_table(result) + _problems(result))
    files.write_text("index.html", html_page(f"spinemesh upgrade: {_shown_name(root)}", _CSS, body))
    files.finish()
    return Path(folder) / "index.html"
