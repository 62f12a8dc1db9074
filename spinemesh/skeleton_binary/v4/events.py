"""Event definitions."""

from __future__ import annotations

from ..symmetric import fld, put as _put, ref, text
from .layout import Context


def event(s, node: dict, c: Context) -> None:
    # Events are a JSON object keyed by name; the list form here is turned into it later.
    if c.L.names_are_refs:
        ref(s, node, "name")
    else:
        text(s, node, "name")
    if s.reading:
        _put(node, "int", s.varint(positive=False), 0)
    else:
        s.varint(node.get("int", 0), positive=False, what="the event's int")
    fld(s, node, "float", 0)
    if c.L.constraint_list:
        # 4.3: "" for no string, as the 4.2 editor stores it and as SkeletonJson defaults
        # (a null here would load as null in SkeletonBinary but "" from the JSON).
        if s.reading:
            v = s.string(what="event string")
            if v:
                node["string"] = v
        else:
            s.string(node.get("string", ""), what="event string")
    else:
        text(s, node, "string")
    text(s, node, "audio")
    if node.get("audio") is not None:
        fld(s, node, "volume", 1)
        fld(s, node, "balance", 0)
