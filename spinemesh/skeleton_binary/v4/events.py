"""Event definitions."""

from __future__ import annotations

from ..symmetric import fld, put as _put, text
from .fields import ref
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
        s.varint(int(node.get("int", 0)), positive=False)
    fld(s, node, "float", 0)
    text(s, node, "string")
    text(s, node, "audio")
    if node.get("audio") is not None:
        fld(s, node, "volume", 1)
        fld(s, node, "balance", 0)
