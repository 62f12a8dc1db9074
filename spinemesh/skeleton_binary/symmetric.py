"""Field helpers shared by every version's declarations (:mod:`.v3`, :mod:`.v4`).

Each reads a value into ``node[key]``, leaving it out when it is the JSON default, or
writes ``node.get(key, default)``; one call serves both directions (see :mod:`.stream`).
``-0.0`` is always kept: it packs to other bytes than ``0.0``.
"""

from __future__ import annotations

import math


def put(node: dict, key: str, v, default) -> None:
    """Set ``node[key] = v`` unless ``v`` is the JSON default (``-0.0`` is kept)."""
    if v != default:
        node[key] = v
    elif type(v) is float and v == 0 and math.copysign(1.0, v) < 0:
        node[key] = v


def fld(s, node: dict, key: str, default=0.0):
    """A float32 that is always stored."""
    if s.reading:
        v = s.f32(what=key)
        put(node, key, v, default)
        return v
    return s.f32(node.get(key, default), what=key)


def boolean(s, node: dict, key: str, default: bool = False) -> bool:
    """A boolean byte."""
    if s.reading:
        v = s.bool(what=key)
        put(node, key, v, default)
        return v
    return s.bool(node.get(key, default))


def color(s, node: dict, key: str, default: str | None):
    """An RGBA8888 colour as ``rrggbbaa``."""
    if s.reading:
        v = s.color(what=key)
        put(node, key, v, default)
        return v
    return s.color(node.get(key, default), what=key)


def text(s, node: dict, key: str):
    """An inline string; null means the key is absent."""
    if s.reading:
        v = s.string(what=key)
        if v is not None:
            node[key] = v
        return v
    return s.string(node.get(key), what=key)


def first_use_table(strings: list[str], refs: list[int]) -> bool:
    """Whether numbering strings in first-use order gives this string table and these
    references (the writer's own table): no duplicate, and the references, in file order,
    first use index 1, then 2, and so on."""
    if len(set(strings)) != len(strings):
        return False
    expected = 1
    for k in refs:
        if k == expected:
            expected += 1
        elif k > expected:
            return False
    return expected - 1 == len(strings)
