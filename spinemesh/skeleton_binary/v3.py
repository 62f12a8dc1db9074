"""The ``.skel`` layout of Spine 3.5, 3.6, 3.7 and 3.8, declared once for reading and writing.

Every declaration below takes a stream ``s`` (a :class:`~.stream.SkelReader` or
:class:`~.stream.SkelWriter`) and the document node it fills (reading) or encodes
(writing). The document is the one the Spine editor's JSON export of the same version
holds: same keys, same nesting, values equal to their defaults left out.

What changed between the four versions is read as data from a :class:`Layout`:

======================  =====  =====  =====  =====
                        3.5    3.6    3.7    3.8
======================  =====  =====  =====  =====
slot dark colour        -      yes    yes    yes
two-colour timelines    -      yes    yes    yes
transform local/rel.    -      yes    yes    yes
point, clipping         -      yes    yes    yes
skeleton ``x``, ``y``   -      -      -      yes
audio paths             -      -      yes    yes
IK compress/stretch     -      -      yes    yes
IK softness             -      -      -      yes
string table (refs)     -      -      -      yes
skin bones/constraints  -      -      -      yes
JSON skins              dict   dict   dict   list
JSON bezier curve       list   list   list   c1..c4
JSON path timelines     paths  paths  paths  path
JSON keys' time 0       kept   kept   kept   left out
======================  =====  =====  =====  =====

3.5 is 3.6 without the four features of the first rows: the same header (hash and
version strings, no ``x``, ``y``), the same bones, constraints, skins, events and
timelines otherwise.

Binary-only information
-----------------------
Two things of a ``.skel`` have no place in the editor's JSON, so they are kept under the
top-level key ``"_skel"`` (absent when derivable) to write the same bytes back:

- ``"nonessential": false`` when the file has no nonessential data (colours of bones and
  non-rendered attachments, mesh edges and size, fps, image and audio paths);
- (3.8) ``"strings"``, the shared string table, when it is not in the order in which the
  document first uses each string (true of all 21 3.8 examples: the editor has its own
  order), and ``"refs"``, the index of every reference, when the table holds a string
  more than once and references pick among the copies.

A document loaded from JSON has no ``"_skel"``: the writer then writes nonessential data
and numbers strings in first-use order.

Facts about the format were learnt from the Spine runtimes' ``SkeletonBinary`` and
``SkeletonJson`` loaders (spine-libgdx, branches 3.5 to 3.8); no code was taken from them.
"""

from __future__ import annotations

import math
import struct

from ..skeleton_curves import curve_spelling
from ..skeleton_version import major_minor
from .enums import ATTACHMENT_TYPES, BLEND, EXTRA, POSITION_MODE, ROTATE_MODE, extra_to_write  # noqa: F401
from .enums import INHERIT as TRANSFORM_MODE
from .stream import RecordedRefs, SkelReader, SkelWriter
from .symmetric import (CONSTRAINT_WORDS, bend, boolean, color, dark_color, enum, first_use_table, fld, index, index_list,
                        name_table, names_once, put, ref, text)

SPACING_MODE = ("length", "fixed", "percent")

from .enums import CURVE_BEZIER, CURVE_LINEAR, CURVE_STEPPED  # noqa: E402,F401


class Layout:
    """What one 3.x minor version stores, as flags read by the declarations.

    Parameters
    ----------
    version : str
        The editor version from the header, e.g. ``"3.8.55"``.
    """

    def __init__(self, version: str):
        self.version = version
        self.minor = major_minor(version)[1]
        self.two_color = self.minor >= 6          # slot dark colour, two-colour timelines
        self.local_relative = self.minor >= 6     # transform constraint local, relative flags
        # Attachment type bytes: 3.6 added point and clipping after the five of 3.5.
        self.attachment_types = ATTACHMENT_TYPES if self.minor >= 6 else ATTACHMENT_TYPES[:5]
        self.bounds_xy = self.minor >= 8          # skeleton x, y before width, height
        self.audio = self.minor >= 7              # skeleton and event audio paths
        self.ik_flags = self.minor >= 7           # IK compress, stretch (uniform on constraints)
        self.softness = self.minor >= 8           # IK softness
        self.refs = self.minor >= 8               # names through the shared string table
        self.skin_required = self.minor >= 8      # "skin" flag on bones and constraints
        self.skins_list = self.minor >= 8         # JSON skins: list of {name, attachments}
        self.curves = curve_spelling(version)      # JSON curve: [c1..c4] before 3.8; 3.8: c1, then c2, c3, c4
        self.time_default = self.minor >= 8       # JSON leaves out a key's time 0
        self.paths_key = "path" if self.minor >= 8 else "paths"

    def ik_frame(self) -> tuple:
        """The values of one IK key, as ``(key, kind, default)`` (see :func:`value`)."""
        out = [("mix", "f", 1)]
        if self.softness:
            out.append(("softness", "f", 0))
        out.append(("bendPositive", "bend", True))
        if self.ik_flags:
            out += [("compress", "bool", False), ("stretch", "bool", False)]
        return tuple(out)

    def slot_timelines(self) -> tuple:
        """The slot timeline types, in the order of their type byte (see :data:`SLOT_TIMELINES`)."""
        return SLOT_TIMELINES if self.two_color else SLOT_TIMELINES[:2]


def layout_of(s, version: str) -> Layout:
    """The layout of ``version``: ``3.5.x`` to ``3.8.x``, or the editor's downgraded
    exports such as ``3.8-from-4.0.64`` (a 3.8 file). 3.4 and older files have another
    layout (inherit flags for a bone's transform mode, no fps, no constraint order) and are
    refused."""
    known = major_minor(version)
    if not (known and known[0] == 3 and 5 <= known[1] <= 8):
        raise s.fail(f"Spine 3.5, 3.6, 3.7 or 3.8, found version {version!r}", 0)
    return Layout(version)


class Context:
    """What the declarations need beyond their own node: the layout and the name tables
    (``(names, name -> index)``) that indices in the binary point into."""

    def __init__(self, layout: Layout, nonessential: bool):
        self.L = layout
        self.nonessential = nonessential
        self.bones = self.slots = self.ik = self.transform = self.path = self.skins = ([], {})
        self.events: list[dict] = []
        self.event_names = ([], {})


# -- small symmetric helpers -----------------------------------------------------------
# Each reads a value into ``node[key]`` (leaving it out when it is the JSON default) or
# writes ``node.get(key, default)``. ``-0.0`` is kept: it packs to other bytes than 0.

_NEVER = object()  # a default no value equals: the value is always kept


def name(s, c: Context, node: dict, key: str):
    """A name: a string-table reference in 3.8, an inline string before; null is absent."""
    return ref(s, node, key) if c.L.refs else text(s, node, key)


def name_value(s, c: Context, value=None, what: str = "name"):
    """:func:`name` for a bare value rather than a key of a node."""
    return (s.string_ref if c.L.refs else s.string)(value, what=what)


def seq(s, items, fn, *args, what: str = "count") -> list:
    """A count, then ``fn(s, item, *args)`` per item; reading collects the results."""
    if s.reading:
        return [fn(s, None, *args) for _ in range(s.count(what=what))]
    s.count(len(items), what=what)
    for item in items:
        fn(s, item, *args)
    return items


def nodes(s, items, fn, *args, what: str = "count") -> list:
    """A count, then ``fn(s, node, *args)`` per dict node; reading creates the nodes."""
    def one(s, node, *args):
        node = {} if node is None else node
        fn(s, node, *args)
        return node
    return seq(s, items, one, *args, what=what)


def floats(s, node: dict, key: str, n: int) -> list:
    """``n`` float32s as a list under ``key``."""
    if s.reading:
        raw = s.raw(n=4 * n, what=f"{key} ({n} floats)")
        v = list(struct.unpack(f">{n}f", raw))
        s.float_sum += sum(v)
        node[key] = v
        return v
    v = node.get(key, [])
    if len(v) != n:
        raise s.fail(f"{n} numbers in {key!r}, got {len(v)}")
    try:
        s.raw(struct.pack(f">{n}f", *v))
    except struct.error:
        raise s.fail(f"numbers in {key!r}") from None
    return v


def shorts(s, node: dict, key: str) -> None:
    """A count and that many 16-bit ints (triangles, edges)."""
    if s.reading:
        n = s.count(what=f"{key} count")
        node[key] = list(struct.unpack(f">{n}H", s.raw(n=2 * n, what=key)))
        return
    v = node.get(key, [])
    s.count(len(v))
    try:
        s.raw(struct.pack(f">{len(v)}H", *v))
    except struct.error:
        raise s.fail(f"16-bit indices in {key!r}") from None


# -- header ----------------------------------------------------------------------------

def header(s, doc: dict, extra: dict) -> Context:
    """The skeleton header: hash, version, bounds and (nonessential) fps and paths.

    Returns the :class:`Context` for the rest of the file; ``extra`` gets (reading) or
    gives (writing) the nonessential flag.
    """
    if s.reading:
        sk = doc["skeleton"] = {}
        text(s, sk, "hash")
        version = s.string(what="version")
        if version is None:
            raise s.fail("a version string")
        sk["spine"] = version
    else:
        sk = doc.get("skeleton", {})
        text(s, sk, "hash")
        version = s.string(str(sk.get("spine", "")))
    L = layout_of(s, version)
    for key in ("x", "y", "width", "height") if L.bounds_xy else ("width", "height"):
        if s.reading:
            sk[key] = s.f32(what=key)
        else:
            s.f32(sk.get(key, 0.0), what=key)
    nonessential = s.bool(extra.get("nonessential", True))
    if nonessential:
        fld(s, sk, "fps", 30)
        text(s, sk, "images")
        if L.audio:
            text(s, sk, "audio")
    if s.reading and not nonessential:
        extra["nonessential"] = False
    return Context(L, nonessential)


# -- bones, slots, constraints ---------------------------------------------------------

_BONE_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1),
                ("shearX", 0), ("shearY", 0), ("length", 0))


def bone(s, node: dict, c: Context, i: int) -> None:
    """One bone; the root (``i == 0``) has no parent index."""
    text(s, node, "name")
    if i > 0:
        index(s, node, "parent", *c.bones, "bone")
    for key, d in _BONE_FIELDS:
        fld(s, node, key, d)
    enum(s, node, "transform", TRANSFORM_MODE, "normal")
    if c.L.skin_required:
        boolean(s, node, "skin")
    if c.nonessential:
        color(s, node, "color", "9b9b9bff")


#: The editor's JSON key order where it differs from the binary's field order.
BONE_ORDER = ("name", "parent", "length", "rotation", "x", "y", "scaleX", "scaleY", "shearX", "shearY",
              "transform", "skin", "color")
ATTACHMENT_ORDER = {
    "region": ("name", "path", "x", "y", "scaleX", "scaleY", "rotation", "width", "height", "color"),
    "mesh": ("name", "type", "path", "color", "uvs", "triangles", "vertices", "hull", "edges", "width", "height"),
    "linkedmesh": ("name", "type", "path", "color", "skin", "parent", "deform", "width", "height"),
    "boundingbox": ("name", "type", "vertexCount", "vertices", "color"),
    "path": ("name", "type", "closed", "constantSpeed", "lengths", "vertexCount", "vertices", "color"),
    "point": ("name", "type", "x", "y", "rotation", "color"),
    "clipping": ("name", "type", "end", "vertexCount", "vertices", "color"),
}


def _ordered(node: dict, keys: tuple) -> dict:
    """``node`` with ``keys`` first, in that order (a read's cosmetic last step)."""
    return {k: node[k] for k in keys if k in node} | node


def bones(s, doc: dict, c: Context) -> None:
    """The bones, filling ``c.bones`` as they come."""
    # A bone's parent is an index into the bones before it, so the table grows as it goes.
    items = [] if s.reading else doc.get("bones", [])
    names: list = []
    lookup: dict = {}
    c.bones = (names, lookup)
    n = s.count(len(items), what="bone count")
    for i in range(n):
        node = {} if s.reading else items[i]
        bone(s, node, c, i)
        lookup.setdefault(node.get("name"), len(names))
        names.append(node.get("name"))
        if s.reading:
            items.append(_ordered(node, BONE_ORDER))
    if s.reading:
        doc["bones"] = items


def slot(s, node: dict, c: Context) -> None:
    """One slot: bone, colours, setup attachment, blend mode."""
    text(s, node, "name")
    index(s, node, "bone", *c.bones, "bone")
    color(s, node, "color", "ffffffff")
    if c.L.two_color:
        dark_color(s, node, "dark")
    name(s, c, node, "attachment")
    enum(s, node, "blend", BLEND, "normal")


def _constraint_head(s, node: dict, c: Context) -> None:
    """What all constraints start with: name, order, (3.8) skin flag, bones."""
    text(s, node, "name")
    if s.reading:
        node["order"] = s.varint(what="order")  # the editor writes it, 0 included
    else:
        s.varint(node.get("order", 0))
    if c.L.skin_required:
        boolean(s, node, "skin")
    index_list(s, node, "bones", c.bones, "bone")


def ik(s, node: dict, c: Context) -> None:
    """One IK constraint."""
    _constraint_head(s, node, c)
    index(s, node, "target", *c.bones, "bone")
    fld(s, node, "mix", 1)
    if c.L.softness:
        fld(s, node, "softness", 0)
    bend(s, node, "bendPositive")
    if c.L.ik_flags:
        boolean(s, node, "compress")
        boolean(s, node, "stretch")
        boolean(s, node, "uniform")


_TRANSFORM_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 0), ("scaleY", 0), ("shearY", 0),
                     ("rotateMix", 1), ("translateMix", 1), ("scaleMix", 1), ("shearMix", 1))


def transform(s, node: dict, c: Context) -> None:
    """One transform constraint: target, local/relative flags, offsets, mixes."""
    _constraint_head(s, node, c)
    index(s, node, "target", *c.bones, "bone")
    if c.L.local_relative:
        boolean(s, node, "local")
        boolean(s, node, "relative")
    for key, d in _TRANSFORM_FIELDS:
        fld(s, node, key, d)


def path_constraint(s, node: dict, c: Context) -> None:
    """One path constraint; its target is a slot."""
    _constraint_head(s, node, c)
    index(s, node, "target", *c.slots, "slot")
    enum(s, node, "positionMode", POSITION_MODE, "percent")
    enum(s, node, "spacingMode", SPACING_MODE, "length")
    enum(s, node, "rotateMode", ROTATE_MODE, "tangent")
    for key, d in (("rotation", 0), ("position", 0), ("spacing", 0), ("rotateMix", 1), ("translateMix", 1)):
        fld(s, node, key, d)


def constraints(s, doc: dict, key: str, fn, c: Context) -> tuple:
    """A list of constraints under ``doc[key]`` (left out when empty); returns their name table."""
    items = nodes(s, None if s.reading else doc.get(key, []), fn, c, what=f"{key} constraint count")
    names_once(s, [x.get("name") for x in items], key, CONSTRAINT_WORDS[key])
    if s.reading and items:
        doc[key] = items
    return name_table([x.get("name") for x in items])


# -- attachments -----------------------------------------------------------------------

def vertices(s, node: dict, n: int, c: Context) -> None:
    """``n`` vertices: ``2n`` floats, or (weighted) per vertex a bone count and
    ``(bone, x, y, weight)`` per bone, flat as in the JSON."""
    v = node.get("vertices", [])
    weighted = s.bool(len(v) != 2 * n, what="weighted flag")
    if not weighted:
        floats(s, node, "vertices", 2 * n)
        return
    nbones = len(c.bones[0])
    if s.reading:
        out: list = []
        for _ in range(n):
            k = s.count(what="bones per vertex")
            out.append(k)
            for _ in range(k):
                at = s.pos
                b = s.varint(what="bone index")
                if not 0 <= b < nbones:
                    raise s.fail(f"bone index below {nbones}, found {b}", at)
                out.append(b)
                out += struct.unpack(">3f", s.raw(n=12, what="weighted vertex"))
        s.float_sum += sum(out)  # its counts and bone indices are small ints
        node["vertices"] = out
        return
    s.weighted(v, n, nbones)


def vertex_count(s, node: dict) -> int:
    """The ``vertexCount`` of a bounding box, path or clipping attachment."""
    if s.reading:
        n = s.count(what="vertex count")
        node["vertexCount"] = n
        return n
    return s.count(node.get("vertexCount", 0), what="vertex count")


def region(s, node: dict, c: Context) -> None:
    """A region attachment: path, transform, size (always in the JSON), colour."""
    name(s, c, node, "path")
    for key, d in (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1)):
        fld(s, node, key, d)
    for key in ("width", "height"):
        if s.reading:
            node[key] = s.f32(what=key)
        else:
            s.f32(node.get(key, 0), what=key)
    color(s, node, "color", "ffffffff")


def bounding_box(s, node: dict, c: Context) -> None:
    """A bounding box attachment."""
    vertices(s, node, vertex_count(s, node), c)
    if c.nonessential:
        color(s, node, "color", "60f000ff")


def mesh(s, node: dict, c: Context) -> None:
    """A mesh attachment: ``uvs`` (2 per vertex), ``triangles``, ``vertices``, ``hull``
    (vertex count) and, nonessential, ``edges``, ``width``, ``height``."""
    name(s, c, node, "path")
    color(s, node, "color", "ffffffff")
    n = s.count(len(node.get("uvs", [])) // 2, what="vertex count")
    floats(s, node, "uvs", 2 * n)
    shorts(s, node, "triangles")
    vertices(s, node, n, c)
    if s.reading:
        node["hull"] = s.count(what="hull length")
    else:
        s.count(node.get("hull", 0), what="hull length")
    if c.nonessential:
        shorts(s, node, "edges")
        fld(s, node, "width", 0)
        fld(s, node, "height", 0)


def linked_mesh(s, node: dict, c: Context) -> None:
    """A linked mesh: a mesh sharing its ``parent``'s geometry (``skin`` null: default)."""
    name(s, c, node, "path")
    color(s, node, "color", "ffffffff")
    name(s, c, node, "skin")
    name(s, c, node, "parent")
    boolean(s, node, "deform", True)
    if c.nonessential:
        fld(s, node, "width", 0)
        fld(s, node, "height", 0)


def path_attachment(s, node: dict, c: Context) -> None:
    """A path attachment: bezier control points and one length per curve."""
    boolean(s, node, "closed")
    boolean(s, node, "constantSpeed", True)
    n = vertex_count(s, node)
    vertices(s, node, n, c)
    floats(s, node, "lengths", n // 3)
    if c.nonessential:
        color(s, node, "color", "ff7f00ff")


def point(s, node: dict, c: Context) -> None:
    """A point attachment."""
    for key in ("rotation", "x", "y"):
        fld(s, node, key, 0)
    if c.nonessential:
        color(s, node, "color", "f1f100ff")


def clipping(s, node: dict, c: Context) -> None:
    """A clipping attachment, clipping up to the ``end`` slot."""
    index(s, node, "end", *c.slots, "slot")
    vertices(s, node, vertex_count(s, node), c)
    if c.nonessential:
        color(s, node, "color", _NEVER if s.reading else "ce3a3aff")  # the editor writes it


ATTACHMENTS = {"region": region, "boundingbox": bounding_box, "mesh": mesh, "linkedmesh": linked_mesh,
               "path": path_attachment, "point": point, "clipping": clipping}

def attachment(s, node: dict, c: Context) -> dict:
    """One attachment: name (null when it is the key), type byte, then its type's fields.
    Returns the node (reading: a new one in the editor's key order)."""
    name(s, c, node, "name")
    types = c.L.attachment_types
    if s.reading:
        at = s.pos
        t = s.u8(what="attachment type")
        if t >= len(types):
            raise s.fail(f"an attachment type below {len(types)}, found {t}", at)
        kind = types[t]
        if kind != "region":
            node["type"] = kind
    else:
        kind = node.get("type", "region")
        if kind not in types:
            raise s.fail(f"an attachment type of Spine {c.L.version} {types}, got {kind!r}")
        s.u8(types.index(kind))
    ATTACHMENTS[kind](s, node, c)
    if s.reading:
        node = _ordered(node, ATTACHMENT_ORDER[kind])
    return node


def skin_attachments(s, slots: dict, c: Context) -> dict:
    """Attachments of one skin: per slot (an index), per key, an attachment."""
    items = [] if s.reading else list(slots.items())
    n = s.count(len(items), what="skin slot count")
    out: dict = {}
    for i in range(n):
        slot_name, atts = (None, None) if s.reading else items[i]
        box = {"slot": slot_name}
        index(s, box, "slot", *c.slots, "slot")
        keys = [] if s.reading else list(atts.items())
        m = s.count(len(keys), what="attachment count")
        got = out.setdefault(box["slot"], {})
        for j in range(m):
            key, node = (None, {}) if s.reading else keys[j]
            key = name_value(s, c, key, "attachment key")
            got[key] = attachment(s, node, c)
    return out


def skins(s, doc: dict, c: Context) -> None:
    """The default skin (attachments only), then the named skins.

    The JSON holds them as a name-keyed object (3.6, 3.7) or a list of
    ``{"name", "bones", "ik", "transform", "path", "attachments"}`` (3.8).
    """
    L = c.L
    if s.reading:
        listed = []
        default = skin_attachments(s, {}, c)
        if default:
            listed.append({"name": "default", "attachments": default})
        for _ in range(s.count(what="skin count")):
            sk: dict = {}
            name(s, c, sk, "name")
            if L.skin_required:
                skin_members(s, sk, c)
            sk["attachments"] = skin_attachments(s, {}, c)
            listed.append(sk)
        names_once(s, [sk.get("name") for sk in listed], "skins", "skins")
        doc["skins"] = listed if L.skins_list else {sk["name"]: sk["attachments"] for sk in listed}
        c.skins = name_table([sk.get("name") for sk in listed])
        return
    listed = written_skins(doc, L)
    names_once(s, [sk.get("name") for sk in listed], "skins", "skins")
    default = next((sk for sk in listed if sk.get("name") == "default"), None)
    skin_attachments(s, default["attachments"] if default else {}, c)
    others = [sk for sk in listed if sk is not default]
    s.count(len(others), what="skin count")
    for sk in others:
        name(s, c, sk, "name")
        if L.skin_required:
            skin_members(s, sk, c)
        skin_attachments(s, sk.get("attachments", {}), c)
    # Deform timelines index the runtime's skins: the default one only when it has slots.
    kept = [default] if default and default["attachments"] else []
    c.skins = name_table([sk.get("name") for sk in kept + others])


def written_skins(doc: dict, L: Layout) -> list[dict]:
    """The document's skins as a list of ``{"name", "attachments", ...}`` nodes."""
    raw = doc.get("skins", [] if L.skins_list else {})
    if isinstance(raw, dict):
        return [{"name": k, "attachments": v} for k, v in raw.items()]
    return [dict(sk, attachments=sk.get("attachments", {})) for sk in raw]


def skin_members(s, sk: dict, c: Context) -> None:
    """The bones and constraints a 3.8 skin requires."""
    index_list(s, sk, "bones", c.bones, "bone", keep_empty=False)
    for key, table in (("ik", c.ik), ("transform", c.transform), ("path", c.path)):
        index_list(s, sk, key, table, CONSTRAINT_WORDS[key][:-1], keep_empty=False)


# -- events ----------------------------------------------------------------------------

def event(s, node: dict, c: Context) -> None:
    """One event definition."""
    name(s, c, node, "name")
    if s.reading:
        put(node, "int", s.varint(positive=False, what="int"), 0)
    else:
        s.varint(node.get("int", 0), positive=False, what="the event's int")
    fld(s, node, "float", 0)
    # The editor writes "" for no string, and its JSON leaves that out; a null is kept.
    if s.reading:
        v = s.string(what="string")
        if v != "":
            node["string"] = v
    else:
        s.string(node.get("string", ""), what="string")
    if c.L.audio:
        text(s, node, "audio")
        if node.get("audio") is not None:
            fld(s, node, "volume", 1)
            fld(s, node, "balance", 0)


# -- animations ------------------------------------------------------------------------

class Always:
    """A key value the JSON always holds, whatever its value: the version's JSON loader
    requires it, or its default there differs from the usual one (3.6/3.7 scale keys
    default to 0). ``default`` is what the writer uses when a document lacks it."""

    def __init__(self, default):
        self.default = default


def value(s, f: dict, key: str, kind: str, default) -> None:
    """One value of a key: ``"f"`` float32, ``"rgba"`` colour, ``"rgb"`` dark colour,
    ``"bend"`` bend direction byte, ``"bool"`` boolean."""
    if isinstance(default, Always):
        if not s.reading and key not in f:
            f = {key: default.default}
        default = _NEVER
    if kind == "f":
        fld(s, f, key, default)
    elif kind == "rgba":
        color(s, f, key, default)
    elif kind == "rgb":
        dark_color(s, f, key)
    elif kind == "bend":
        bend(s, f, key)
    else:
        boolean(s, f, key, default)


def time(s, f: dict, c: Context) -> None:
    """A key's time in seconds (3.8's JSON leaves out 0)."""
    if s.reading:
        t = s.f32(what="time")
        if not c.L.time_default or t != 0 or math.copysign(1.0, t) < 0:
            f["time"] = t
    else:
        s.f32(f.get("time", 0), what="time")


def curve(s, f: dict, c: Context) -> None:
    """The curve from a key to the next: linear (left out), ``"stepped"`` or a bezier."""
    if s.reading:
        at = s.pos
        kind = s.u8(what="curve type")
        if kind == CURVE_STEPPED:
            f["curve"] = "stepped"
        elif kind == CURVE_BEZIER:
            c1, c2, c3, c4 = struct.unpack(">4f", s.raw(n=16, what="bezier curve"))
            s.float_sum += c1 + c2 + c3 + c4
            if not c.L.curves.bezier_in_list:
                f["curve"] = c1
                put(f, "c2", c2, 0)
                put(f, "c3", c3, 1)
                put(f, "c4", c4, 1)
            else:
                f["curve"] = [c1, c2, c3, c4]
        elif kind != CURVE_LINEAR:
            raise s.fail(f"a curve type 0, 1 or 2, found {kind}", at)
        return
    # the curve the version's runtime draws reading the JSON (a 3.7 key's number is linear there)
    kind = c.L.curves.kind(f)
    if kind != "bezier":
        s.u8(CURVE_STEPPED if kind == "stepped" else CURVE_LINEAR)
        return
    s.u8(CURVE_BEZIER)
    controls = c.L.curves.controls(f)
    try:
        s.raw(struct.pack(">4f", *controls))
    except (struct.error, OverflowError):  # not numbers, or beyond a float32 (1e39, 400 digits)
        from ..skeleton_check import found

        raise s.fail("a bezier curve of 4 numbers a 32-bit float holds, got "
                     + ", ".join(map(found, controls))) from None


def frames(s, items, c: Context, values: tuple, what: str = "frame count") -> list:
    """Keys of a curve timeline: time, ``values`` and, but for the last, a curve."""
    n = s.count(None if s.reading else len(items), what=what)
    out = [] if s.reading else items
    for i in range(n):
        f = {} if s.reading else items[i]
        time(s, f, c)
        for key, kind, default in values:
            value(s, f, key, kind, default)
        if i < n - 1:
            curve(s, f, c)
        if s.reading:
            out.append(f)
    return out


def attachment_frames(s, items, c: Context, values=None) -> list:
    """Keys of an attachment timeline: time and attachment name, no curves."""
    def one(s, f, c):
        f = {} if f is None else f
        time(s, f, c)
        v = name_value(s, c, f.get("name"), "attachment name")
        if s.reading:
            f["name"] = v
        return f
    return seq(s, items, one, c, what="frame count")


#: Timeline types per group, in the order of their type byte: (JSON key, values), each
#: value ``(key, kind, default)``. The JSON loaders require colour keys' colours; 3.6 and
#: 3.7 also every bone key's values (the editor writes them all).
SLOT_TIMELINES = (("attachment", None),
                  ("color", (("color", "rgba", Always("ffffffff")),)),
                  ("twoColor", (("light", "rgba", Always("ffffffff")), ("dark", "rgb", Always("ffffff")))))
BONE_TIMELINES = {
    "3.8": (("rotate", (("angle", "f", 0),)),
            ("translate", (("x", "f", 0), ("y", "f", 0))),
            ("scale", (("x", "f", 1), ("y", "f", 1))),
            ("shear", (("x", "f", 0), ("y", "f", 0)))),
    "3.6": (("rotate", (("angle", "f", Always(0)),)),
            ("translate", (("x", "f", Always(0)), ("y", "f", Always(0)))),
            ("scale", (("x", "f", Always(0)), ("y", "f", Always(0)))),
            ("shear", (("x", "f", Always(0)), ("y", "f", Always(0))))),
}
PATH_TIMELINES = (("position", (("position", "f", 0),)),
                  ("spacing", (("spacing", "f", 0),)),
                  ("mix", (("rotateMix", "f", 1), ("translateMix", "f", 1))))
TRANSFORM_FRAME = (("rotateMix", "f", 1), ("translateMix", "f", 1), ("scaleMix", "f", 1), ("shearMix", "f", 1))


def typed_timelines(s, timelines: dict, c: Context, table: tuple, what: str) -> dict:
    """A count, then per timeline its type byte and keys (slots, bones, path constraints)."""
    items = [] if s.reading else list(timelines.items())
    kinds = [k for k, _ in table]
    n = s.count(len(items), what=f"{what} timeline count")
    out: dict = {}
    for i in range(n):
        at = s.pos
        if s.reading:
            t = s.u8(what=f"{what} timeline type")
            if t >= len(table):
                raise s.fail(f"a {what} timeline type below {len(table)}, found {t}", at)
            kind, fs = table[t][0], None
        else:
            kind, fs = items[i]
            if kind not in kinds:
                raise s.fail(f"a {what} timeline of {kinds}, got {kind!r}")
            s.u8(kinds.index(kind))
        values = table[kinds.index(kind)][1]
        if values is None:
            out[kind] = attachment_frames(s, fs, c)
        else:
            out[kind] = frames(s, fs, c, values)
    return out


def keyed(s, anim: dict, key: str, table: tuple, what: str, body) -> None:
    """A count, then per item (an index into ``table``) its timelines from ``body``."""
    group = anim.get(key, {}) if not s.reading else {}
    items = [] if s.reading else list(group.items())
    n = s.count(len(items), what=f"{what} count")
    out: dict = {}
    for i in range(n):
        box = {} if s.reading else {"k": items[i][0]}
        index(s, box, "k", *table, what)
        out[box["k"]] = body(s, None if s.reading else items[i][1])
    if s.reading and out:
        anim[key] = out


def deform(s, anim: dict, c: Context) -> None:
    """Deform timelines: per skin, per slot, per attachment, keys of vertex offsets."""
    def one_frame(s, f, i, n):
        time(s, f, c)
        verts = f.get("vertices", [])
        end = s.count(len(verts), what="deform length")
        if end:
            if s.reading:
                put(f, "offset", s.count(what="deform offset"), 0)
            else:
                s.count(f.get("offset", 0), what="deform offset")
            floats(s, f, "vertices", end)
        if i < n - 1:
            curve(s, f, c)

    def attachment_keys(s, fs):
        n = s.count(None if s.reading else len(fs), what="frame count")
        out = [] if s.reading else fs
        for i in range(n):
            f = {} if s.reading else fs[i]
            one_frame(s, f, i, n)
            if s.reading:
                out.append(f)
        return out

    def by_attachment(s, atts):
        items = [] if s.reading else list(atts.items())
        out = {}
        for i in range(s.count(len(items), what="deform attachment count")):
            key = name_value(s, c, None if s.reading else items[i][0], "attachment key")
            out[key] = attachment_keys(s, None if s.reading else items[i][1])
        return out

    def by_slot(s, slots):
        box = {"deform": slots}
        keyed(s, box, "deform", c.slots, "slot", by_attachment)
        return box.get("deform", {})

    keyed(s, anim, "deform", c.skins, "skin", by_slot)


def draw_order(s, anim: dict, c: Context) -> None:
    """Draw order keys: per key, the slots that move and by how many places."""
    def offset(s, o):
        o = {} if o is None else o
        index(s, o, "slot", *c.slots, "slot")
        if s.reading:
            o["offset"] = s.varint(what="draw order offset")
        else:
            s.varint(o.get("offset", 0), what="draw order offset")
        return o

    def key(s, f):
        f = {} if f is None else f
        time(s, f, c)
        offsets = seq(s, f.get("offsets", []), offset, what="draw order offset count")
        if s.reading and offsets:
            f["offsets"] = offsets
        return f

    items = seq(s, anim.get("drawOrder", anim.get("draworder", [])), key, what="draw order key count")
    if s.reading and items:
        anim["drawOrder"] = items


def events_timeline(s, anim: dict, c: Context) -> None:
    """Event keys; a key's values that equal its event's are left out, as in the JSON."""
    defs = c.events

    def key(s, f):
        f = {} if f is None else f
        time(s, f, c)
        index(s, f, "name", *c.event_names, "event")
        data = defs[c.event_names[1][f["name"]]]
        if s.reading:
            put(f, "int", s.varint(positive=False, what="int"), data.get("int", 0))
        else:
            s.varint(f.get("int", data.get("int", 0)), positive=False, what="an event key's int")
        fld(s, f, "float", data.get("float", 0))
        if s.bool("string" in f, what="string flag"):
            text(s, f, "string")
        if c.L.audio and data.get("audio") is not None:
            fld(s, f, "volume", data.get("volume", 1))
            fld(s, f, "balance", data.get("balance", 0))
        return f

    items = seq(s, anim.get("events", []), key, what="event key count")
    if s.reading and items:
        anim["events"] = items


def animation(s, anim: dict, c: Context) -> None:
    """One animation's timelines, group by group in the binary's order."""
    L = c.L
    keyed(s, anim, "slots", c.slots, "slot",
          lambda s, tl: typed_timelines(s, tl, c, L.slot_timelines(), "slot"))
    keyed(s, anim, "bones", c.bones, "bone",
          lambda s, tl: typed_timelines(s, tl, c, BONE_TIMELINES["3.8" if L.minor >= 8 else "3.6"], "bone"))
    keyed(s, anim, "ik", c.ik, "IK constraint", lambda s, fs: frames(s, fs, c, L.ik_frame()))
    keyed(s, anim, "transform", c.transform, "transform constraint",
          lambda s, fs: frames(s, fs, c, TRANSFORM_FRAME))
    keyed(s, anim, L.paths_key, c.path, "path constraint",
          lambda s, tl: typed_timelines(s, tl, c, PATH_TIMELINES, "path"))
    deform(s, anim, c)
    draw_order(s, anim, c)
    events_timeline(s, anim, c)


# -- the whole file --------------------------------------------------------------------

def body(s, doc: dict, c: Context) -> None:
    """Everything after the header (and the 3.8 string table)."""
    bones(s, doc, c)
    items = nodes(s, None if s.reading else doc.get("slots", []), slot, c, what="slot count")
    names_once(s, [x.get("name") for x in items], "slots", "slots")
    if s.reading:
        doc["slots"] = items
    c.slots = name_table([x.get("name") for x in items])
    c.ik = constraints(s, doc, "ik", ik, c)
    c.transform = constraints(s, doc, "transform", transform, c)
    c.path = constraints(s, doc, "path", path_constraint, c)
    skins(s, doc, c)
    # Events: a list in the binary, a name-keyed object in the JSON.
    if s.reading:
        items = nodes(s, None, event, c, what="event count")
        names_once(s, [e.get("name") for e in items], "events", "events")
        c.events = [{k: v for k, v in e.items() if k != "name"} for e in items]
        c.event_names = name_table([e.get("name") for e in items])
        if items:
            doc["events"] = dict(zip(c.event_names[0], c.events))
    else:
        evs = doc.get("events", {})
        c.events = list(evs.values())
        c.event_names = name_table(list(evs))
        nodes(s, [dict(v, name=k) for k, v in evs.items()], event, c, what="event count")
    anims = {} if s.reading else doc.get("animations", {})
    items = list(anims.items())
    n = s.count(len(items), what="animation count")
    for i in range(n):
        key = s.string(None if s.reading else items[i][0], what="animation name")
        if s.reading and key in anims:
            names_once(s, [*anims, key], "animations", "animations")
        anim = {} if s.reading else items[i][1]
        animation(s, anim, c)
        anims[key] = anim
    if s.reading:
        doc["animations"] = anims


class _RefReader(SkelReader):
    """A reader that records the string-table index of every reference: the editor's
    table may hold a string twice, and only the indices tell which copy was used."""

    def __init__(self, data, path=None):
        super().__init__(data, path)
        self.refs: list[int] = []

    def string_ref(self, value=None, what: str = "string reference"):
        at = self.pos
        v = super().string_ref(value, what)
        self.pos = at
        self.refs.append(self.varint())
        return v


class _GrowingTableWriter(SkelWriter):
    """A writer that builds the string table as it goes, numbering new strings in first-use order."""

    def string_ref(self, value, what: str = "string reference"):
        if value is None:
            self.varint(0)
            return None
        if not isinstance(value, str):
            raise self.fail(f"a string for {what}, got {value!r}")
        k = self._string_index.get(value)
        if k is None:
            k = self._string_index[value] = len(self.strings)
            self.strings.append(value)
        self.varint(k + 1)
        return value


class _TableWriter(RecordedRefs, _GrowingTableWriter):
    """Replays recorded indices where they still name the same string; new strings are
    added to the table in first-use order."""

    def __init__(self, path=None, strings: list | None = None, refs: list | None = None):
        super().__init__(path)
        self.set_strings(strings or [])
        self.replay(refs)


def read(reader: SkelReader) -> dict:
    """Read a whole 3.6/3.7/3.8 ``.skel`` into a JSON-layout document."""
    r = _RefReader(reader.data, reader.path)
    r.pos = reader.pos
    doc: dict = {}
    extra: dict = {}
    try:
        c = header(r, doc, extra)
        if c.L.refs:
            n = r.count(what="string count")
            r.strings = [r.string(what="table string") for _ in range(n)]
            if any(x is None for x in r.strings):
                raise r.fail("non-null strings in the string table")
        body(r, doc, c)
        if not r.at_end:
            raise r.fail(f"end of file, found {len(r.data) - r.pos} more bytes")
    finally:
        reader.pos = r.pos
        reader.float_sum += r.float_sum
    if c.L.refs and not first_use_table(r.strings, r.refs):
        # The editor's own table order (not first use): keep it, and the indices too
        # when some reference does not point at its string's first copy.
        extra["strings"] = list(r.strings)
        first = {}
        for i, x in enumerate(r.strings):
            first.setdefault(x, i + 1)
        if any(k and first[r.strings[k - 1]] != k for k in r.refs):
            extra["refs"] = list(r.refs)
    if extra:
        doc[EXTRA] = extra
    return doc


def write(writer, doc: dict) -> None:
    """Encode a document (read from ``.skel`` or loaded from JSON) as 3.x ``.skel`` bytes."""
    extra = extra_to_write(writer, doc)
    head = SkelWriter(writer.path)
    rest = _TableWriter(writer.path, extra.get("strings"), extra.get("refs"))
    try:
        c = header(head, doc, extra)
        body(rest, doc, c)
    except (AttributeError, TypeError, ValueError, KeyError, IndexError, ArithmeticError, struct.error) as e:
        # A document whose values have the wrong types (e.g. a hand-edited JSON).
        raise (rest if rest.pos else head).fail(
            f"a well-formed 3.x skeleton document ({type(e).__name__}: {e})") from None
    writer.raw(head.getvalue())
    if c.L.refs:
        writer.count(len(rest.strings))
        for x in rest.strings:
            writer.string(x)
    writer.raw(rest.getvalue())
