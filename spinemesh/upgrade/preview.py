"""``upgrade --preview DIR``: one self-contained HTML page that shows what an upgrade changed.

The page (``DIR/index.html``, images inlined as PNG data URIs, vectors as inline SVG, no
script) has:

- a summary: attachments meshed, kept and failed, and the project's **fill rate**: texels
  drawn before (each region draws the rectangle its atlas stores) and after (the mesh), and
  how many of them were fully transparent. Transparent texels cost the GPU as much as visible
  ones, which is the saving that matters to game teams;
- per skeleton, its **setup pose** drawn by our own geometry (bone world transforms from
  :mod:`spinemesh.rig.bones`, attachments placed as the runtimes place them) with the
  wireframe of every upgraded attachment that the setup pose shows;
- per upgraded image, the sprite with the old quad (dashed) and the new mesh, vertex and
  triangle counts and the transparent area no longer drawn.

Counts are texels of the image as the atlas stores it (a page exported at scale 0.5 has a
quarter of the texels); each upgraded attachment counts once.
"""

from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..attachment_geometry import region_quad_transform
from ..fsutil import atomic_write_text
from ..images import fit_within, png_data_uri
from ..project import find_project, image_source_for
from ..skeleton import AttachmentRef, image_paths, iter_skins, load_skeleton

#: Largest side of the setup-pose picture and of a sprite picture, pixels.
POSE_SIZE = 900
CARD_SIZE = 300
#: Most images shown per skeleton (largest saving first), so that the page stays light.
CARD_LIMIT = 200


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


# --- setup pose ---------------------------------------------------------------------------

def _attachment_geometry(att: dict, slot_bone: int, worlds: list[np.ndarray]
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """UVs (N, 2), skeleton-space positions (N, 2) and triangles of a region or mesh attachment.

    ``worlds`` are the bones' setup-pose world transforms (2, 3), ``slot_bone`` the index of
    the slot's bone; weighted meshes are placed by :func:`spinemesh.rig.binding.setup_world`.
    """
    kind = att.get("type", "region")
    world = worlds[slot_bone]
    if kind == "region":
        corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
        quad = region_quad_transform(att)
        local = corners @ quad[:, :2].T + quad[:, 2]
        return corners, local @ world[:, :2].T + world[:, 2], np.array([[0, 1, 2], [0, 2, 3]])
    if kind != "mesh":
        return None
    from ..rig.binding import parse_vertices, setup_world

    uvs, tris, _ = _mesh_arrays(att)
    return uvs, setup_world(parse_vertices(att, len(worlds)), worlds, slot_bone), tris


def _draw(canvas: np.ndarray, rgba: np.ndarray, uvs: np.ndarray, dst: np.ndarray, tris: np.ndarray) -> None:
    """Composite an image drawn through a triangle mesh onto ``canvas`` (H, W, 3 float, 0..1).

    When one affine map carries every vertex (a region, or a mesh made from one), the image is
    warped once and masked by the triangles, so no seam shows between them.
    """
    import cv2

    h, w = rgba.shape[:2]
    src = uvs * (w, h)
    ones = np.c_[src, np.ones(len(src))]
    affine, *_ = np.linalg.lstsq(ones, dst, rcond=None)
    pieces = [(affine.T, tris)] if np.abs(ones @ affine - dst).max() < 0.5 else [
        (cv2.getAffineTransform(src[t].astype(np.float32), dst[t].astype(np.float32)), t[None]) for t in tris]
    H, W = canvas.shape[:2]
    for m, part in pieces:
        x0, y0 = np.floor(dst[part.ravel()].min(axis=0)).astype(int).clip(0, (W, H))
        x1, y1 = np.ceil(dst[part.ravel()].max(axis=0) + 1).astype(int).clip(0, (W, H))
        if x1 <= x0 or y1 <= y0:
            continue
        m = np.asarray(m, float).copy()
        m[:, 2] -= (x0, y0)
        warped = cv2.warpAffine(rgba, m, (int(x1 - x0), int(y1 - y0)), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0)).astype(np.float32) / 255
        inside = np.zeros(warped.shape[:2], np.uint8)
        for t in part:
            cv2.fillConvexPoly(inside, np.round((dst[t] - (x0, y0)) * 16).astype(np.int32), 1, shift=4)
        a = warped[..., 3:4] * inside[..., None]
        roi = canvas[y0:y1, x0:x1]
        roi[:] = warped[..., :3] * a + roi * (1 - a)


def pose_skins(doc: dict) -> list[str]:
    """The skins the setup pose is drawn with, first match first: the skin that supplies most of
    the slots' setup attachments (a project whose default skin is empty dresses it in one), then
    ``default``, as a runtime falls back to the default skin."""
    skins = dict(iter_skins(doc))
    wanted = [(s.get("name"), str(s["attachment"])) for s in doc.get("slots", [])
              if isinstance(s, dict) and s.get("attachment") is not None]

    def supplies(skin: str) -> int:
        return sum(isinstance((skins[skin].get(slot) or {}).get(name), dict) for slot, name in wanted)

    best = max((k for k in skins if k != "default"), key=supplies, default=None)
    return ([best] if best is not None and supplies(best) else []) + (["default"] if "default" in skins else [])


def _bone_lines(bones, to_canvas) -> list[str]:
    """SVG for every bone with a length: a line from its origin along its length, a dot at the origin.

    ``to_canvas`` maps world points, shape (n, 2), to the picture's pixels.
    """
    lines = []
    for bone in bones:
        if bone.length > 0 and np.isfinite(bone.world).all():
            (x0, y0), (x1, y1) = to_canvas(bone.segment())
            lines.append(f'<line x1="{x0:.1f}" y1="{y0:.1f}" x2="{x1:.1f}" y2="{y1:.1f}" class="bone"/>'
                         f'<circle cx="{x0:.1f}" cy="{y0:.1f}" r="2.5" class="joint"/>')
    return lines


def setup_pose(doc: dict, source, upgraded: set[tuple[str, str, str]], draw_bones: bool = False) -> str:
    """HTML (a PNG under an SVG) of a skeleton's setup pose, with the wireframes of ``upgraded``.

    Parameters
    ----------
    doc : dict
        The upgraded skeleton.
    source : image source or None
        Where the images come from (see :func:`spinemesh.project.image_source_for`).
    upgraded : set of (skin, slot, attachment name)
        Attachments whose wireframe is drawn.
    draw_bones : bool
        Also draw every bone with a length (a green line from its origin, a dot at the origin),
        as ``--weights auto`` binds meshes to them.
    """
    from ..errors import SpineMeshError
    from ..rig.bones import skeleton_bones

    bones = skeleton_bones(doc)
    by_name = {b.name: b for b in bones}
    worlds = [b.world for b in bones]
    skins = dict(iter_skins(doc))
    order = pose_skins(doc)
    parts = []
    for slot in doc.get("slots", []):
        if not isinstance(slot, dict) or slot.get("attachment") is None or slot.get("bone") not in by_name:
            continue
        name = str(slot["attachment"])
        found = [(k, skins[k][slot.get("name")][name]) for k in order
                 if isinstance((skins[k].get(slot.get("name")) or {}).get(name), dict)]
        if not found:
            continue
        skin, att = found[0]
        try:
            geometry = _attachment_geometry(att, by_name[slot["bone"]].index, worlds)
        except (SpineMeshError, TypeError, ValueError, IndexError):
            continue  # malformed numbers or bone indices: the rest of the pose is still drawn
        if geometry is None:
            continue
        paths = image_paths(AttachmentRef(skin, slot.get("name"), name, att))
        parts.append(((skin, slot.get("name"), name), att, paths, geometry))
    if not parts:
        return "<p>The setup pose shows no region or mesh attachment.</p>"
    everything = np.concatenate([g[1] for *_, g in parts])
    lo, hi = everything.min(axis=0), everything.max(axis=0)
    k = (POSE_SIZE - 20) / max(float((hi - lo).max()), 1e-6)
    W, H = (np.ceil((hi - lo) * k) + 20).astype(int)

    def to_canvas(p: np.ndarray) -> np.ndarray:  # skeleton y is up, pictures' y is down
        return np.c_[(p[:, 0] - lo[0]) * k + 10, (hi[1] - p[:, 1]) * k + 10]

    canvas = np.full((H, W, 3), 0.93, np.float32)
    wires = []
    for place, att, paths, (uvs, pos, tris) in parts:
        dst = to_canvas(pos)
        image = None
        if source is not None and paths:
            try:
                image = source.get(paths[0])
                _draw(canvas, image.rgba, uvs, dst, tris)
            except SpineMeshError:
                pass  # a missing image: its wireframe (if upgraded) still shows where it is
        if place in upgraded and att.get("type") == "mesh":
            wires.append(_mesh_svg(uvs, tris, int(att.get("hull", 0)), lambda _uv, d=dst: d, 1.0))
        elif att.get("type", "region") == "region":  # left a region: the rectangle it draws, dashed
            corners = dst
            if image is not None:  # the part of the image its atlas stores, as on the cards
                h, w = image.rgba.shape[:2]
                x0, y0, x1, y1 = image.content
                box = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float) / (w, h)
                corners = box @ (dst[1] - dst[0], dst[3] - dst[0]) + dst[0]
            points = " ".join(f"{x:.1f},{y:.1f}" for x, y in corners)
            wires.append(f'<polygon points="{points}" class="quad" stroke-width="1.2"/>')
    if draw_bones:
        wires += _bone_lines(bones, to_canvas)
    png = png_data_uri((canvas * 255).round().astype(np.uint8))
    caption = f"<p>Skins: {html.escape(', '.join(order))}.</p>" if order != ["default"] else ""
    return caption + (f'<div class="pose" style="width:{W}px;height:{H}px"><img src="{png}" width="{W}" height="{H}" '
            f'alt="setup pose"><svg viewBox="0 0 {W} {H}" width="{W}" height="{H}">{"".join(wires)}</svg></div>')


# --- the page ------------------------------------------------------------------------------

_CSS = """
body{font:14px/1.4 system-ui,sans-serif;margin:24px;color:#222;background:#fff}
h1{font-size:22px}h2{font-size:18px;margin-top:32px}
table.sum{border-collapse:collapse}table.sum td,table.sum th{padding:3px 10px;border-bottom:1px solid #ddd;text-align:right}
table.sum td:first-child,table.sum th:first-child{text-align:left}
.big{font-size:20px;font-weight:600;color:#146c2e}
.pose{position:relative;margin:8px 0;border:1px solid #ccc}
.pose img,.pose svg,.card .pic img,.card .pic svg{position:absolute;left:0;top:0}
.cards{display:flex;flex-wrap:wrap;gap:14px}
.card{border:1px solid #ccc;border-radius:6px;padding:8px;width:300px}
.card .pic{position:relative;margin:auto;image-rendering:pixelated;background:repeating-conic-gradient(#ddd 0 25%,#fff 0 50%) 0 0/16px 16px}
.card .name{font-weight:600;word-break:break-all}.card .who{color:#666;font-size:12px;word-break:break-all}
.card td{padding:1px 6px}.card td:nth-child(2),.card td:nth-child(3){text-align:right}
svg .tri{fill:none;stroke:#e0582b;stroke-opacity:.9}svg .hull{fill:none;stroke:#1f5fd1}
svg .quad{fill:none;stroke:#c00;stroke-dasharray:5 4}
svg .bone{stroke:#0a7d3b;stroke-width:2.5;stroke-linecap:round;opacity:.85}svg .joint{fill:#0a7d3b}
.note{color:#555;font-size:12px;margin-top:4px}.bent img{max-width:100%;margin-top:6px}
.legend span{display:inline-block;margin-right:18px}.legend i{display:inline-block;width:22px;height:0;vertical-align:middle;margin-right:6px}
"""

_LEGEND = ('<p class="legend"><span><i style="border-top:3px dashed #c00"></i>old quad (what the region drew)</span>'
           '<span><i style="border-top:3px solid #1f5fd1"></i>new mesh hull</span>'
           '<span><i style="border-top:2px solid #e0582b"></i>new mesh triangles</span></p>')


def _pct(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f}%" if whole else "-"


def _less(part: int, whole: int) -> str:
    """``part`` fewer out of ``whole`` as a change ("−20.1%"), or "-" when there is no whole."""
    return f"−{_pct(part, whole)}" if whole else "-"


def _card(rgba: np.ndarray, box, att: dict, names: list[str], rate: FillRate, frames: int = 1,
          bent: np.ndarray | None = None) -> str:
    """One upgraded image: the sprite with the old quad and the new mesh, its counts and saving.

    ``frames`` > 1: the image is the first frame of a sequence whose one mesh covers every
    frame's art (said under the picture, as the hull can be far larger than this frame's art);
    ``bent``: the weights picture of the mesh (setup pose coloured by bone, one bent pose).
    """
    uvs, tris, hull = _mesh_arrays(att)
    h, w = rgba.shape[:2]
    pic = fit_within(rgba, CARD_SIZE - 20)
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
    return (f'<div class="card"><div class="name">{html.escape(att.get("path") or names[0].rsplit("/", 1)[-1])}</div>'
            f'<div class="who">{who}</div>'
            f'<div class="pic" style="width:{pw}px;height:{ph}px"><img src="{png_data_uri(pic)}" width="{pw}" '
            f'height="{ph}" alt="">{svg}</div>{table}'
            f'<div>transparent area no longer drawn: <b>{saved:,}</b> texels '
            f'({_pct(saved, rate.transparent_before)} of it)</div>'
            + (f'<div class="note">One mesh for the {frames} frames of this sequence: it covers the art of '
               'every frame, so it reaches beyond the art of the frame shown.</div>' if frames > 1 else "")
            + (f'<div class="note bent">Bound to its bones (--weights auto): vertices coloured by bone, and '
               f'the mesh with its bones turned:<img src="{png_data_uri(bent)}" alt="bent pose"></div>'
               if bent is not None else "")
            + '</div>')


def _reasons_table(result) -> str:
    """Why attachments were kept as regions or failed, with counts, most frequent first.

    Reasons worded alike are one row whatever their figures ("the art fills 98% ..." and
    "... 92% ..."), with the most frequent as the example (:func:`spinemesh.runs.reason_groups`);
    reasons worded differently are never folded together.
    """
    from ..runs import reason_groups

    rows = "".join(
        f"<tr><td>{html.escape(status)}</td><td style=\"text-align:left\">{html.escape(example)}"
        + (f" <i>({variants - 1} more like it with other figures)</i>" if variants > 1 else "")
        + f"</td><td>{n:,}</td></tr>"
        for status in ("kept", "failed")
        for example, n, variants in reason_groups([t.reason for t in result.targets if t.status == status]))
    if not rows:
        return ""
    return ('<table class="sum"><tr><th>left a region</th><th style="text-align:left">why (an example)</th>'
            f"<th>attachments</th></tr>{rows}</table>")


class _ImageCache:
    """An image source that decodes each atlas page once per page (not once per lookup) and
    keeps each image it was asked for: the pose and the cards ask for the same images, in orders
    that would make a two-page cache decode pages again and again."""

    def __init__(self, source):
        from ..images import AtlasImages

        if isinstance(source, AtlasImages):
            pages = sum(len(a.pages) for a in source.atlases)
            source = AtlasImages(source.atlases, source.root, cache_pages=min(pages, 8))
        self.source = source
        self.images: dict = {}

    def get(self, name: str):
        if name not in self.images:
            self.images[name] = self.source.get(name)
        return self.images[name]


def _skeleton_section(rel: str, targets: list, doc: dict, source) -> tuple[str, FillRate]:
    """One skeleton's part of the page, and its fill rate over its meshed ``targets``.

    ``doc`` is the upgraded skeleton; ``source`` the project's images (an :class:`_ImageCache`,
    or None when the project has none for it).
    """
    cards, seen = [], {}
    for t in targets:
        seen.setdefault(t.key, []).append(t)
    skeleton_rate = FillRate(0, 0, 0, 0)
    weighted = any(t.weights is not None for t in targets)
    rig = None
    for key, group in seen.items():
        t = group[0]
        att = _find(doc, t.skin, t.slot, t.name)
        if att is None or source is None:
            continue
        image = source.get(t.paths[0])
        uvs, tris, _ = _mesh_arrays(att)
        rate = fill_rate(image.rgba, image.content, uvs, tris)
        for _ in group:  # every attachment drawing this image saves as much
            skeleton_rate = skeleton_rate + rate
        bent = None
        if weighted and len((t.weights or {}).get("bones") or {}) > 1 and t.weights.get("status") == "weighted":
            from ..rig.document import build_rig
            from ..rig.preview import weighted_picture

            rig = rig or build_rig(doc)
            bent = weighted_picture(doc, att, rig, image.rgba)
        cards.append((rate.transparent_before - rate.transparent_after,
                      _card(image.rgba, image.content, att, [f"{g.skin}/{g.slot}/{g.name}" for g in group], rate,
                            frames=len(t.paths), bent=bent)))
    cards.sort(key=lambda c: -c[0])
    more = len(cards) - CARD_LIMIT
    cards = cards[:CARD_LIMIT] + ([(0, f"<p>… and {more} more images with smaller savings (counted in the "
                                          "totals).</p>")] if more > 0 else [])
    upgraded = {(t.skin, t.slot, t.name) for t in targets}
    return (
        f"<h2>{html.escape(rel)}</h2><p>{len(targets)} attachments meshed; transparent texels drawn "
        f"{skeleton_rate.transparent_before:,} → {skeleton_rate.transparent_after:,} "
        f"({_less(skeleton_rate.transparent_before - skeleton_rate.transparent_after, skeleton_rate.transparent_before)})."
        f" Setup pose, drawn from the upgraded skeleton: wireframes of the new meshes, regions left as they "
        f"are dashed:</p>"
        + setup_pose(doc, source, upgraded, draw_bones=weighted)
        + f"<h3>Upgraded images, largest saving first</h3>{_LEGEND}<div class=\"cards\">"
        + "".join(c for _, c in cards) + "</div>", skeleton_rate)


def _headline(result, total: FillRate) -> str:
    """The page's headline: the saving, or, when nothing was measured, what happened instead."""
    if total.transparent_before:
        return f"{_pct(total.transparent_before - total.transparent_after, total.transparent_before)} fewer " \
               "transparent texels drawn"
    counts = result.counts()
    if result.not_read and not counts.get("meshed"):
        n = len(result.not_read)
        return f"Nothing meshed: {n} skeleton{'s' if n > 1 else ''} could not be read (see below)"
    if counts.get("failed") and not counts.get("meshed"):
        return f"Nothing meshed: {counts['failed']} attachments failed (see why below)"
    if not result.targets:
        return "Nothing to upgrade: no region attachment (every attachment is already a mesh or of another type)"
    if counts.get("meshed") and total.before:
        return f"{counts['meshed']} attachments meshed; their images hold no transparent texel to leave out"
    if counts.get("meshed"):
        return f"{counts['meshed']} attachments meshed (their images could not be read for this page)"
    return "Nothing meshed: every region was kept as it is (see why below)"


def _problems(result) -> str:
    """The skeletons that could not be read and the other errors, one line each (or nothing)."""
    if not result.errors:
        return ""
    unread = set(result.not_read.values())
    items = [f"<li><b>not read:</b> {html.escape(e)}</li>" for e in result.not_read.values()]
    items += [f"<li>{html.escape(e)}</li>" for e in result.errors if e not in unread]
    return f"<h3>Problems</h3><ul>{''.join(items)}</ul>"


def write_preview(result, project: str | Path, out: str | Path, folder: str | Path,
                  images_in: str | Path | None = None, on_skeleton=None) -> Path:
    """Write ``folder/index.html`` for an upgrade run and return its path.

    Parameters
    ----------
    result : spinemesh.upgrade.report.Result
        What :func:`~spinemesh.upgrade.upgrade_project` returned.
    project : path
        The project (folder or skeleton file) that was upgraded: images are read from it.
    out : path
        The output folder the upgraded skeletons were written to.
    images_in : path, optional
        The ``--from-images`` folder, if the run used one.
    on_skeleton : callable, optional
        Called with no argument after each skeleton's part of the page (for progress bars).
    """
    from ..errors import SpineMeshError

    proj = find_project(project)
    out, folder = Path(out), Path(folder)
    total = FillRate(0, 0, 0, 0)
    sections = []
    for rel in result.written:
        if on_skeleton is not None and sections:
            on_skeleton()  # the previous skeleton's part is done
        targets = [t for t in result.targets if t.skeleton == rel and t.status == "meshed"]
        try:
            doc = load_skeleton(out / rel)
            source = image_source_for(load_skeleton(proj.root / rel), proj.root / rel, proj, images=images_in)
        except SpineMeshError as e:
            sections.append(f"<h2>{html.escape(rel)}</h2><p>not shown: {html.escape(str(e))}</p>")
            continue
        source = None if source is None else _ImageCache(source)
        section, skeleton_rate = _skeleton_section(rel, targets, doc, source)
        total = total + skeleton_rate
        sections.append(section)
    if on_skeleton is not None and sections:
        on_skeleton()
    counts = result.counts()
    saved = total.transparent_before - total.transparent_after
    summary = (
        f'<p class="big">{html.escape(_headline(result, total))}</p>'
        '<table class="sum"><tr><th></th><th>regions (before)</th><th>meshes (after)</th><th>change</th></tr>'
        f"<tr><td>texels drawn</td><td>{total.before:,}</td><td>{total.after:,}</td>"
        f"<td>{_less(total.before - total.after, total.before)}</td></tr>"
        f"<tr><td>of them fully transparent</td><td>{total.transparent_before:,}</td>"
        f"<td>{total.transparent_after:,}</td><td>{_less(saved, total.transparent_before)}</td></tr></table>"
        f"<p>Attachments: {counts.get('meshed', 0)} meshed, {counts.get('kept', 0)} kept as regions, "
        f"{counts.get('failed', 0)} failed. Each upgraded attachment counts once, in texels of its atlas "
        "image; a region draws the rectangle its atlas stores, a mesh only its triangles.</p>"
        + _reasons_table(result) + _problems(result))
    page = (f"<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>spinemesh upgrade: "
            f"{html.escape(proj.root.name)}</title><style>{_CSS}</style></head><body>"
            f"<h1>spinemesh upgrade: {html.escape(str(project))} → {html.escape(str(out))}</h1>"
            f"{summary}{''.join(sections)}</body></html>\n")
    path = folder / "index.html"
    atomic_write_text(path, page)
    return path
