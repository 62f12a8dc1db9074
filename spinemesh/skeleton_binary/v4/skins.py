"""Skins: the default skin's attachments, then named skins with their bones and constraints."""

from __future__ import annotations

from ..symmetric import CONSTRAINT_WORDS, color, index_list, ref, text
from .attachments import attachment
from .bones import _bone_list
from .constraint_list import skin_constraints
from .fields import seq
from .layout import Context


def skin_attachments(s, skin: dict, c: Context, nslots: int | None = None) -> None:
    names, lookup = c.slots
    if s.reading:
        atts = {}
        for _ in range(nslots):
            at = s.pos
            i = s.varint()
            if not 0 <= i < len(names):
                raise s.fail(f"slot index below {len(names)}, found {i}", at)
            slot_atts = atts.setdefault(names[i], {})
            c.slot_name = names[i]
            for _ in range(s.count(what="attachment count")):
                key = s.string_ref()
                if key is None:
                    raise s.fail("an attachment name", s.pos - 1)
                node = {}
                attachment(s, node, key, c)
                slot_atts[key] = node
        if atts:
            skin["attachments"] = atts
        return
    for slot_name, slot_atts in skin.get("attachments", {}).items():
        if slot_name not in lookup:
            raise s.fail(f"a known slot in skin {skin.get('name')!r}, got {slot_name!r}")
        s.varint(lookup[slot_name])
        c.slot_name = slot_name
        s.count(len(slot_atts))
        for key, node in slot_atts.items():
            s.string_ref(key)
            attachment(s, node, key, c)


def _constraint_names(s, skin: dict, key: str, table: tuple) -> None:
    """The constraints of one type a skin holds (:func:`~..symmetric.index_list`), left out when none."""
    index_list(s, skin, key, table, CONSTRAINT_WORDS[key][:-1], keep_empty=False)


def skin(s, node: dict, c: Context) -> None:
    if c.L.names_are_refs:
        ref(s, node, "name")
    else:
        text(s, node, "name")
    if c.nonessential and c.L.flags:
        color(s, node, "color", "fe9e4fff")
    _bone_list(s, node, c)
    if s.reading and not node["bones"]:
        del node["bones"]
    if c.L.constraint_list:
        skin_constraints(s, node, c)
    else:
        _constraint_names(s, node, "ik", c.ik)
        _constraint_names(s, node, "transform", c.transform)
        _constraint_names(s, node, "path", c.path)
        if c.L.physics:
            _constraint_names(s, node, "physics", c.physics)
    c.skin_name = node.get("name")
    nslots = s.count(len(node.get("attachments", {})), what="skin slot count")
    skin_attachments(s, node, c, nslots)


def skins(s, doc: dict, c: Context) -> None:
    if s.reading:
        out = doc["skins"] = []
        nslots = s.count(what="default skin slot count")
        if nslots:
            default = {"name": "default"}
            skin_attachments(s, default, c, nslots)
            out.append(default)
        out.extend(seq(s, None, skin, c, what="skin count"))
        return
    items = _written_skins(doc)
    default = items[0] if items and items[0].get("name") == "default" else None
    if default is None:
        s.count(0)
    else:
        s.count(len(default.get("attachments", {})))
        skin_attachments(s, default, c)
    seq(s, items[1:] if default is not None else items, skin, c)


def _written_skins(doc: dict) -> list:
    """The skins as the binary has them: a default skin without attachments has no place
    there (its slot count 0 means "no default skin"), and skin indices skip it."""
    items = doc.get("skins", [])
    if items and items[0].get("name") == "default" and not items[0].get("attachments"):
        return items[1:]
    return items
