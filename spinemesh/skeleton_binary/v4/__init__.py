"""The ``.skel`` layout of Spine 4.0 to 4.3, declared once for reading and writing.

Every declaration in this package (one module per structure: :mod:`.header`, :mod:`.bones`,
:mod:`.constraints`, :mod:`.constraint_list`, :mod:`.attachments`, :mod:`.skins`, :mod:`.events`,
:mod:`.timelines`, :mod:`.animation`) takes a stream ``s`` (a
:class:`~spinemesh.skeleton_binary.stream.SkelReader` or
:class:`~spinemesh.skeleton_binary.stream.SkelWriter`) and the document node it fills (reading)
or encodes (writing). The document is the one the Spine editor's JSON export of the same version
holds: same keys, same nesting, values equal to their defaults left out.

What the four versions change is read as data from a :class:`Layout`: 4.1 added
sequences and attachment timelines; 4.2 packs optional fields behind flag bytes, adds
physics constraints, inherit timelines, a reference scale, bone icons and visibility;
4.3 keeps every constraint in one typed list with sliders (:mod:`.constraint_list`) and
adds draw order folders, animation colours and a few attachment fields (see
:class:`Layout`).

Reading is done by :class:`_RefReader`, a reader with bulk methods for the hot spots
(mesh arrays, weighted vertices, timeline frames); writing by :class:`_RefWriter`.

Binary-only information
-----------------------
A few things of a ``.skel`` have no place in the editor's JSON. They are kept under the
top-level key ``"_skel"``, absent when everything is derivable, so that reading and
writing a ``.skel`` gives back the same bytes:

- ``"nonessential": false`` when the file lacks nonessential data (colours, mesh edges and
  sizes, bone icons...);
- ``"strings"`` and ``"refs"``: the shared string table and the index each string reference
  used. The editor's table may hold a string twice and in any order; the writer's own
  table (:func:`string_table`) holds each once, in order of first use;
- ``"timelines"``: per animation, the stored timeline count where it is not the one
  :func:`.animation.timeline_count` derives (never seen in the examples);
- ``"timelineSlots"`` (4.3): ``[skin, slot, mesh, [slot, ...]]`` for meshes whose stored
  timeline slots differ from those the runtime derives from linked meshes
  (:func:`~.attachments.derived_timeline_slots`).

A document loaded from JSON has no ``"_skel"``; the writer then writes nonessential data
and its own string table. If a document was edited so that it uses strings the recorded
table lacks, the recorded table is dropped the same way.

Facts about the format were learnt from the Spine runtimes' ``SkeletonBinary`` and
``SkeletonJson`` loaders (spine-libgdx, branches 4.0 to 4.2; for 4.3, the npm package
``@esotericsoftware/spine-core`` 4.3.13); no code was taken from them.
"""

from __future__ import annotations

import struct

from ..enums import EXTRA, extra_to_write
from ..stream import SkelReader
from ..symmetric import CONSTRAINT_WORDS, first_use_table, names_once
from .animation import animation
from .attachments import derived_timeline_slots
from .bones import bones, slot
from .constraint_list import constraint_list, slider_animations
from .constraints import ik, path_constraint, physics, transform
from .events import event
from .fields import _names, seq
from .header import header
from .layout import Context, Layout
from .skins import _written_skins, skins
from .streams import _RefReader, _RefWriter


def _constraints(s, doc: dict, key: str, fn, c: Context) -> tuple:
    if s.reading:
        items = seq(s, None, fn, c, what=f"{key} count")
        if items:
            doc[key] = items
    else:
        items = doc.get(key, [])
        seq(s, items, fn, c)
    names_once(s, [x.get("name") for x in items], key, CONSTRAINT_WORDS[key])
    return _names(items)


def skeleton(s, doc: dict) -> dict:
    """The whole file, in file order."""
    extra = {} if s.reading else dict(doc.get(EXTRA, {}))
    L, nonessential = header(s, doc, extra)
    c = Context(L, nonessential)
    _string_table(s, doc, extra, L)
    bones(s, doc, c)
    _slots(s, doc, c)
    if L.constraint_list:
        constraint_list(s, doc, c)
    else:
        c.ik = _constraints(s, doc, "ik", ik, c)
        c.transform = _constraints(s, doc, "transform", transform, c)
        c.path = _constraints(s, doc, "path", path_constraint, c)
        if L.physics:
            c.physics = _constraints(s, doc, "physics", physics, c)
    _skins(s, doc, extra, c)
    _events(s, doc, c)
    _animations(s, doc, extra, c)
    if L.constraint_list:
        slider_animations(s, doc, c)
    if s.reading:
        _finish_read(s, doc, extra, c)
    return doc


def _string_table(s, doc: dict, extra: dict, L: Layout) -> None:
    """The shared string table: as read, as recorded in ``extra``, or the writer's own."""
    if s.reading:
        s.strings = [s.string() for _ in range(s.count(what="string count"))]
        if any(x is None for x in s.strings):
            raise s.fail("non-null strings in the string table")
        return
    strings = extra.get("strings")
    derived = string_table(doc, L)
    if strings is None or not set(derived) <= set(strings):
        # No recorded table, or the document now uses strings it lacks.
        strings = derived
        s.refs = []
    s.set_strings(strings)
    s.count(len(strings))
    for x in strings:
        s.string(x)


def _slots(s, doc: dict, c: Context) -> None:
    if s.reading:
        items = seq(s, None, slot, c, what="slot count")
        names_once(s, [x.get("name") for x in items], "slots", "slots")
        doc["slots"] = items
        c.slots = _names(items)
    else:
        items = doc.get("slots", [])
        names_once(s, [x.get("name") for x in items], "slots", "slots")
        c.slots = _names(items)
        seq(s, items, slot, c)


def _skins(s, doc: dict, extra: dict, c: Context) -> None:
    """Skins; then, reading, each linked mesh's skin index resolved to its name."""
    if not s.reading:
        listed = _written_skins(doc)
        names_once(s, [sk.get("name") for sk in listed], "skins", "skins")
        c.skins = _names(listed)
        if c.L.constraint_list:
            c.timeline_slots = derived_timeline_slots(doc)
            for skin_name, slot_name, name, slots in extra.get("timelineSlots", []):
                c.timeline_slots[(skin_name, slot_name, name)] = slots
        skins(s, doc, c)
        return
    skins(s, doc, c)
    names_once(s, [sk.get("name") for sk in doc["skins"]], "skins", "skins")
    c.skins = _names(doc["skins"])
    for node, at in c.linked:
        i = node["skin"]
        if not 0 <= i < len(c.skins[0]):
            raise s.fail(f"skin index below {len(c.skins[0])}, found {i}", at)
        node["skin"] = c.skins[0][i]
        if node["skin"] == "default":
            del node["skin"]
    if c.L.constraint_list:
        # Mesh timeline slots the runtime would not derive from the JSON are kept aside.
        derived = derived_timeline_slots(doc)
        kept = [[*where, slots] for where, slots in c.timeline_slots.items() if derived.get(where, []) != slots]
        if kept:
            extra["timelineSlots"] = kept


def _events(s, doc: dict, c: Context) -> None:
    """Events: a list in the binary, a name-keyed object in the JSON."""
    if s.reading:
        items = seq(s, None, event, c, what="event count")
        names_once(s, [e.get("name") for e in items], "events", "events")
        c.events = items
        c.event_names = _names(items)
        if items:
            doc["events"] = {e.pop("name", ""): e for e in items}
            for e, name in zip(items, c.event_names[0]):
                e["name"] = name
        return
    items = [dict(v, name=k) for k, v in doc.get("events", {}).items()]
    c.events = items
    c.event_names = _names(items)
    seq(s, items, event, c)


def _animations(s, doc: dict, extra: dict, c: Context) -> None:
    counts = extra.setdefault("timelines", {}) if s.reading else extra.get("timelines", {})
    if s.reading:
        anims = doc["animations"] = {}
        for _ in range(s.count(what="animation count")):
            name = s.string(what="animation name")
            if name in anims:
                names_once(s, [*anims, name], "animations", "animations")
            anim: dict = {}
            animation(s, anim, c, counts, name)
            anims[name] = anim
        if not counts:
            del extra["timelines"]
        return
    anims = doc.get("animations", {})
    s.count(len(anims))
    for name, anim in anims.items():
        s.string(name)
        animation(s, anim, c, counts, name)


def _finish_read(s, doc: dict, extra: dict, c: Context) -> None:
    """The end of the file, and what the document keeps under ``EXTRA``."""
    for e in c.events:
        e.pop("name", None)
    if not s.at_end:
        raise s.fail(f"end of file, found {len(s.data) - s.pos} more bytes")
    refs = getattr(s, "refs", [])
    if not first_use_table(s.strings, refs):
        extra["strings"] = list(s.strings)
        extra["refs"] = list(refs)
    if extra:
        doc[EXTRA] = extra


def string_table(doc: dict, L: Layout) -> list[str]:
    """The string table the editor writes: every string-table value once, in first use order."""
    seen: dict[str, None] = {}

    def add(v):
        if v is not None and v not in seen:
            seen[v] = None

    for sl in doc.get("slots", []):
        add(sl.get("attachment"))
    for sk in doc.get("skins", []):
        if L.names_are_refs and sk.get("name") != "default":
            add(sk.get("name"))
        for slot_atts in sk.get("attachments", {}).values():
            for key, att in slot_atts.items():
                add(key)
                add(att.get("name"))
                add(att.get("path"))
                if att.get("type") == "linkedmesh":
                    if L.names_are_refs:
                        add(att.get("skin"))
                    add(att.get("source" if L.constraint_list else "parent"))
    if L.names_are_refs:
        for name in doc.get("events", {}):
            add(name)
    for anim in doc.get("animations", {}).values():
        for timelines in anim.get("slots", {}).values():
            for f in timelines.get("attachment", []):
                add(f.get("name"))
        group = anim.get("attachments", anim.get("deform", {}))
        for by_slot in group.values():
            for by_att in by_slot.values():
                for name in by_att:
                    add(name)
    return list(seen)


def read(reader: SkelReader) -> dict:
    """Read a whole 4.0/4.1/4.2 ``.skel`` into a JSON-layout document."""
    r = _RefReader(reader.data, reader.path)
    r.pos = reader.pos
    doc: dict = {}
    try:
        skeleton(r, doc)
    finally:
        reader.pos = r.pos
        reader.float_sum += r.float_sum
    return _json_order(doc)


def write(writer, doc: dict) -> None:
    """Encode a document (read from ``.skel`` or loaded from JSON) as 4.x ``.skel`` bytes."""
    extra = extra_to_write(writer, doc)
    w = _RefWriter(writer.path, extra.get("refs") if extra.get("strings") is not None else None)
    try:
        skeleton(w, doc)
    except (AttributeError, TypeError, ValueError, KeyError, IndexError, ArithmeticError, struct.error) as e:
        # A document whose values have the wrong types (e.g. a hand-edited JSON).
        raise w.fail(f"a well-formed 4.x skeleton document ({type(e).__name__}: {e})") from None
    writer.raw(w.getvalue())


_TOP_ORDER = ("skeleton", "bones", "slots", "constraints", "ik", "transform", "path", "physics", "skins",
              "events", "animations", EXTRA)


def _json_order(doc: dict) -> dict:
    """Top-level keys in the order of the editor's export."""
    return {k: doc[k] for k in _TOP_ORDER if k in doc} | {k: v for k, v in doc.items() if k not in _TOP_ORDER}
