"""Attachments of every type, in the 4.0/4.1 layout and the flag-byte layout of 4.2."""

from __future__ import annotations

import struct

from ..enums import ATTACHMENT_TYPES
from ..symmetric import boolean, color, fld, index, put as _put, ref
from .fields import _to_end, fields, flag, fld_int, floats, opt
from .layout import Context, Layout


def sequence(s, node: dict, present: bool) -> None:
    if not present:
        return
    sq = node.setdefault("sequence", {}) if s.reading else node["sequence"]
    fld_int(s, sq, "count", -1)
    fld_int(s, sq, "start", 1)
    fld_int(s, sq, "digits", 0)
    fld_int(s, sq, "setup", 0)


def vertices(s, node: dict, weighted: bool | None, c: Context, count_key: str | None = "vertexCount",
             n: int | None = None) -> int:
    """Vertex count, then plain ``x, y`` pairs or, when weighted, per vertex
    ``boneCount, (bone, x, y, weight) * boneCount``: the JSON's ``vertices`` layout.

    ``weighted`` is ``None`` for 4.0/4.1, where a boolean before the data says it. ``n``
    is the vertex count when it came earlier (4.0/4.1 meshes store it before the uvs).
    Returns the vertex count.
    """
    counted = n is not None
    if s.reading:
        if not counted:
            n = s.count(what="vertex count")
        if count_key:
            node[count_key] = n
        if weighted is None:
            weighted = s.bool()
        if not weighted:
            node["vertices"] = floats(s, None, 2 * n, "vertices")
        else:
            at = s.pos
            total = s.count(what="length of the weighted vertices' bone list") if c.L.constraint_list else None
            node["vertices"] = s.weighted(None, n, len(c.bones[0]))
            if total is not None and total != _bone_list_length(node["vertices"], n):
                raise s.fail(f"{n} weighted vertices with {total} bone entries, "
                             f"found {_bone_list_length(node['vertices'], n)}", at)
        return n
    verts = node.get("vertices", [])
    if not counted:
        n = _vertex_count(node, count_key)
        s.count(n)
    is_weighted = len(verts) != 2 * n
    if weighted is None:
        s.bool(is_weighted)
    if not is_weighted:
        floats(s, verts, 2 * n, "vertices")
    else:
        if c.L.constraint_list:
            s.count(_bone_list_length(verts, n))
        s.weighted(verts, n, len(c.bones[0]))
    return n


def _bone_list_length(verts: list, n: int) -> int:
    """4.3 stores, before weighted vertices, how long the runtime's bone list for them is:
    per vertex its bone count and its bones."""
    total = i = 0
    for _ in range(n):
        if i >= len(verts):
            break
        k = int(verts[i])
        total += 1 + k
        i += 1 + 4 * k
    return total


def _vertex_count(node: dict, count_key: str | None) -> int:
    if count_key and count_key in node:
        return int(node[count_key])
    if "uvs" in node:
        return len(node["uvs"]) // 2
    return len(node.get("vertices", [])) // 2


def _weighted(node: dict, count_key: str | None) -> bool:
    return len(node.get("vertices", [])) != 2 * _vertex_count(node, count_key)


def shorts(s, node: dict, key: str, n: int | None, c: Context) -> None:
    """Triangles or edges: int16s after a count (4.0/4.1), varints of a known count (4.2)."""
    if s.reading:
        if c.L.short_arrays:
            n = s.count(what=f"{key} count")
            node[key] = list(struct.unpack(f">{n}h", s.raw(n=2 * n, what=key)))
        else:
            if n is None:
                n = s.count(what=f"{key} count")
            if n < 0:
                raise s.fail(f"a mesh with at least 3 vertices, found {n // 3} {key}")
            node[key] = s.varints(None, n, key)
        return
    items = node.get(key, [])
    if c.L.short_arrays:
        s.count(len(items))
        try:
            s.raw(struct.pack(f">{len(items)}h", *items))
        except struct.error:
            raise s.fail(f"16-bit {key}") from None
        return
    if n is None:
        s.count(len(items))
    elif n != len(items):
        raise s.fail(f"{n} {key} indices for this mesh (2 * vertices - hull - 2 triangles), got {len(items)}")
    s.varints(items, n)


_REGION_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1),
                  ("width", 0), ("height", 0))


def attachment(s, node: dict, key: str, c: Context) -> None:
    if c.L.flags:
        attachment_42(s, node, key, c)
    else:
        attachment_40(s, node, key, c)


def _type_of(s, node: dict) -> int:
    t = node.get("type", "region")
    if t not in ATTACHMENT_TYPES:
        raise s.fail(f"an attachment type ({', '.join(ATTACHMENT_TYPES)}), got {t!r}")
    return ATTACHMENT_TYPES.index(t)


def _flags_42(s, node: dict, key: str, c: Context) -> int:
    """4.2+'s first byte of an attachment: its type in the low three bits, then flags that
    say which optional fields follow (their meaning depends on the type)."""
    if s.reading:
        at = s.pos
        flags = s.u8()
        t = flags & 7
        if t >= len(ATTACHMENT_TYPES):
            raise s.fail(f"an attachment type below {len(ATTACHMENT_TYPES)}, found {t}", at)
        if t:
            node["type"] = ATTACHMENT_TYPES[t]
        return flags
    t = _type_of(s, node)
    flags = t | (8 if node.get("name", key) != key else 0)
    kind = ATTACHMENT_TYPES[t]
    if kind in IMAGE_KINDS:
        flags |= (16 if node.get("path", node.get("name", key)) != node.get("name", key) else 0) \
            | (32 if node.get("color", "ffffffff") != "ffffffff" else 0) \
            | (64 if node.get("sequence") is not None else 0)
        if kind == "region" and flag(node, "rotation", 0):
            flags |= 128
        if kind == "mesh" and _weighted(node, None):
            flags |= 128
        if kind == "linkedmesh" and node.get("timelines", True):
            flags |= 128
    elif kind == "path":
        flags |= (16 if node.get("closed") else 0) | (32 if node.get("constantSpeed", True) else 0) \
            | (64 if _weighted(node, "vertexCount") else 0)
    elif kind in ("boundingbox", "clipping"):
        flags |= 16 if _weighted(node, "vertexCount") else 0
        if kind == "clipping" and c.L.constraint_list:
            flags |= (32 if node.get("convex") else 0) | (64 if node.get("inverse") else 0)
    return s.u8(flags)


#: Attachment types that draw an image: their flags announce a path, colour and sequence.
IMAGE_KINDS = ("region", "mesh", "linkedmesh")


def _image_head(s, node: dict, flags: int) -> None:
    if flags & 16:
        ref(s, node, "path")
    if flags & 32:
        color(s, node, "color", None)
    sequence(s, node, flags & 64)


def _region_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    _image_head(s, node, flags)
    opt(s, node, "rotation", flags & 128)
    fields(s, node, _REGION_FIELDS[1:])
    if s.reading:
        _to_end(node, ("rotation", "width", "height", "sequence"))


def _box_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    vertices(s, node, bool(flags & 16), c)
    if c.nonessential:
        color(s, node, "color", "60f000ff")


def _mesh_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    _image_head(s, node, flags)
    hull = fld_int(s, node, "hull", None)
    n = vertices(s, node, bool(flags & 128), c, count_key=None)
    if s.reading:
        uvs = floats(s, None, 2 * n, "uvs")
        # Key order of the editor's export: uvs, triangles, vertices, hull.
        verts = node.pop("vertices")
        h = node.pop("hull", None)
        node["uvs"] = uvs
        shorts(s, node, "triangles", (2 * n - hull - 2) * 3, c)
        node["vertices"] = verts
        if h is not None:
            node["hull"] = h
    else:
        floats(s, node.get("uvs", []), 2 * n, "uvs")
        shorts(s, node, "triangles", (2 * n - int(hull) - 2) * 3, c)
    if c.L.constraint_list:
        _timeline_slots(s, key, c)
    if c.nonessential:
        shorts(s, node, "edges", None, c)
        fld(s, node, "width", 0)
        fld(s, node, "height", 0)


def _timeline_slots(s, key: str, c: Context) -> None:
    """4.3: the slots of linked meshes that share this mesh's timelines. The JSON has no
    place for them: the runtime derives them; see :func:`derived_timeline_slots`."""
    names, lookup = c.slots
    where = (c.skin_name, c.slot_name, key)
    if s.reading:
        slots = []
        for _ in range(s.count(what="timeline slot count")):
            tmp: dict = {}
            index(s, tmp, "k", names, lookup, "slot")
            slots.append(tmp["k"])
        c.timeline_slots[where] = slots
        return
    slots = c.timeline_slots.get(where, [])
    s.count(len(slots))
    for name in slots:
        index(s, {"k": name}, "k", names, lookup, "slot")


def _linked_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    _image_head(s, node, flags)
    if s.reading and not flags & 128:
        node["timelines"] = False
    if c.L.constraint_list:
        # 4.3: the source mesh may sit in another slot; the JSON names it only then.
        if s.reading:
            tmp: dict = {}
            index(s, tmp, "k", *c.slots, "slot")
            if tmp["k"] != c.slot_name:
                node["slot"] = tmp["k"]
        else:
            index(s, {"k": node.get("slot", c.slot_name)}, "k", *c.slots, "slot")
    if s.reading:
        # The skin may come later in the file: resolved once every skin is read.
        at = s.pos
        node["skin"] = s.varint()
        c.linked.append((node, at))
    else:
        tmp = {"skin": node.get("skin", "default")}
        index(s, tmp, "skin", *c.skins, "skin")
    ref(s, node, "source" if c.L.constraint_list else "parent")
    if c.nonessential:
        fld(s, node, "width", 0)
        fld(s, node, "height", 0)


def _path_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    if s.reading:
        _put(node, "closed", bool(flags & 16), False)
        _put(node, "constantSpeed", bool(flags & 32), True)
    n = vertices(s, node, bool(flags & 64), c)
    node_lengths(s, node, n)
    if c.nonessential:
        color(s, node, "color", "ff7f00ff")
    if s.reading:
        _to_end(node, ("vertexCount", "vertices", "color"))  # the JSON has lengths first


def _point_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    point(s, node, c)


def _clipping_42(s, node: dict, flags: int, key: str, c: Context) -> None:
    index(s, node, "end", *c.slots, "slot")
    vertices(s, node, bool(flags & 16), c)
    if s.reading and c.L.constraint_list:
        _put(node, "convex", bool(flags & 32), False)
        _put(node, "inverse", bool(flags & 64), False)
    if c.nonessential:
        color(s, node, "color", "ce3a3aff")


_KINDS_42 = {"region": _region_42, "boundingbox": _box_42, "mesh": _mesh_42, "linkedmesh": _linked_42,
             "path": _path_42, "point": _point_42, "clipping": _clipping_42}


def attachment_42(s, node: dict, key: str, c: Context) -> None:
    """An attachment in the layout of 4.2 and 4.3: the flag byte, the name where it is not
    the key, then the type's fields."""
    flags = _flags_42(s, node, key, c)
    if flags & 8:
        ref(s, node, "name")
    _KINDS_42[ATTACHMENT_TYPES[flags & 7]](s, node, flags, key, c)


def derived_timeline_slots(doc: dict) -> dict:
    """4.3: for each mesh, the slots of linked meshes that share its timelines from another
    slot, as the runtime derives them from JSON: ``{(skin, slot, mesh): [slot, ...]}``."""
    out: dict = {}
    skins = doc.get("skins", [])
    for sk in skins if isinstance(skins, list) else []:
        for slot, atts in sk.get("attachments", {}).items():
            for att in atts.values():
                if att.get("type") != "linkedmesh" or not att.get("timelines", True):
                    continue
                source_slot = att.get("slot", slot)
                if source_slot != slot:
                    slots = out.setdefault((att.get("skin", "default"), source_slot, att.get("source")), [])
                    if slot not in slots:
                        slots.append(slot)
    return out


def node_lengths(s, node: dict, n: int) -> None:
    if s.reading:
        node["lengths"] = floats(s, None, n // 3, "path lengths")
    else:
        floats(s, node.get("lengths", []), n // 3, "path lengths")


def point(s, node: dict, c: Context) -> None:
    fld(s, node, "rotation", 0)
    fld(s, node, "x", 0)
    fld(s, node, "y", 0)
    if c.nonessential:
        color(s, node, "color", "f1f100ff")


def attachment_40(s, node: dict, key: str, c: Context) -> None:
    L = c.L
    ref(s, node, "name")
    if s.reading:
        at = s.pos
        t = s.u8()
        if t >= len(ATTACHMENT_TYPES):
            raise s.fail(f"an attachment type below {len(ATTACHMENT_TYPES)}, found {t}", at)
        if t:
            node["type"] = ATTACHMENT_TYPES[t]
    else:
        t = s.u8(_type_of(s, node))
    kind = ATTACHMENT_TYPES[t]
    if kind == "region":
        ref(s, node, "path")
        fields(s, node, _REGION_FIELDS, order=(1, 2, 3, 4, 0, 5, 6))
        color(s, node, "color", "ffffffff")
        _sequence_40(s, node, L)
        if s.reading:
            # The JSON has the colour before the geometry.
            _to_end(node, ("x", "y", "scaleX", "scaleY", "rotation", "width", "height", "sequence"))
    elif kind == "boundingbox":
        vertices(s, node, None, c)
        if c.nonessential:
            color(s, node, "color", "60f000ff")
    elif kind == "mesh":
        ref(s, node, "path")
        color(s, node, "color", "ffffffff")
        if s.reading:
            n = s.count(what="vertex count")
            node["uvs"] = floats(s, None, 2 * n, "uvs")
            shorts(s, node, "triangles", None, c)
        else:
            n = s.count(_vertex_count(node, None))
            floats(s, node.get("uvs", []), 2 * n, "uvs")
            shorts(s, node, "triangles", None, c)
        vertices(s, node, None, c, count_key=None, n=n)
        fld_int(s, node, "hull", None)
        _sequence_40(s, node, L)
        if c.nonessential:
            shorts(s, node, "edges", None, c)
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "linkedmesh":
        ref(s, node, "path")
        color(s, node, "color", "ffffffff")
        ref(s, node, "skin")
        ref(s, node, "parent")
        boolean(s, node, L.linked_key, True)
        _sequence_40(s, node, L)
        if c.nonessential:
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "path":
        boolean(s, node, "closed", False)
        boolean(s, node, "constantSpeed", True)
        n = vertices(s, node, None, c)
        node_lengths(s, node, n)
        if c.nonessential:
            color(s, node, "color", "ff7f00ff")
    elif kind == "point":
        point(s, node, c)
    elif kind == "clipping":
        index(s, node, "end", *c.slots, "slot")
        vertices(s, node, None, c)
        if c.nonessential:
            color(s, node, "color", "ce3a3aff")


def _sequence_40(s, node: dict, L: Layout) -> None:
    if not L.sequences:
        return
    present = s.bool(node.get("sequence") is not None)
    sequence(s, node, present)
