"""Bones and slots."""

from __future__ import annotations

from ..enums import BLEND, INHERIT
from ..symmetric import boolean, color, dark_color, enum, fld, index, index_list, ref, text
from .fields import _names, _to_end, fields
from .layout import Context

_BONE_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1),
                ("shearX", 0), ("shearY", 0), ("length", 0))


def bone(s, node: dict, c: Context, i: int) -> None:
    if s.reading:
        node["name"] = s.string(what="bone name")
        if i > 0:
            index(s, node, "parent", *c.bones, "bone")
            c.bones[0].append(node["name"])
        else:
            c.bones[0].append(node["name"])
    else:
        s.string(node.get("name"))
        if i > 0:
            # A parent comes before its children: the reader knows only earlier bones.
            parent = c.bones[1].get(node.get("parent"))
            if parent is not None and parent >= i:
                raise s.fail(f"bone {node.get('name')!r} to come after its parent {node.get('parent')!r}")
            index(s, node, "parent", *c.bones, "bone")
    if c.L.constraint_list:
        # 4.3: the length comes after the inherit mode.
        fields(s, node, _BONE_FIELDS[:7])
        enum(s, node, c.L.inherit_key, INHERIT, "normal", as_byte=True)
        fld(s, node, "length", 0)
        if s.reading:
            _to_end(node, tuple(k for k in node if k not in ("name", "parent", "length")))
    else:
        fields(s, node, _BONE_FIELDS, order=(7, 0, 1, 2, 3, 4, 5, 6))  # the JSON has length first
        enum(s, node, c.L.inherit_key, INHERIT, "normal", as_byte=c.L.flags)
    boolean(s, node, "skin")
    if c.nonessential:
        color(s, node, "color", "9b9b9bff")
        if c.L.flags:
            text(s, node, "icon")
            if c.L.constraint_list:
                fld(s, node, "iconSize", 1)
                fld(s, node, "iconRotation", 0)
            boolean(s, node, "visible", True)


def bones(s, doc: dict, c: Context) -> None:
    if s.reading:
        c.bones = ([], {})
        out = doc["bones"] = []
        for i in range(s.count(what="bone count")):
            node = {}
            bone(s, node, c, i)
            out.append(node)
        c.bones = (c.bones[0], {n: i for i, n in reversed(list(enumerate(c.bones[0])))})
    else:
        items = doc.get("bones", [])
        c.bones = _names(items)
        s.count(len(items))
        for i, node in enumerate(items):
            bone(s, node, c, i)


def slot(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    index(s, node, "bone", *c.bones, "bone")
    color(s, node, "color", "ffffffff")
    dark_color(s, node, "dark")
    ref(s, node, "attachment")
    enum(s, node, "blend", BLEND, "normal")
    if c.nonessential and c.L.flags:
        boolean(s, node, "visible", True)


def _bone_list(s, node: dict, c: Context, key: str = "bones") -> None:
    """The bones a constraint or a skin names (:func:`~..symmetric.index_list`), kept when empty."""
    index_list(s, node, key, c.bones, "bone")
