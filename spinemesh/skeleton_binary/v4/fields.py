"""Symmetric helpers: one call reads a field into a node or writes it from the node."""

from __future__ import annotations

import math
import struct

from ..symmetric import fld, name_table, put as _put

_STRUCTS: dict[int, tuple] = {}


def _floats_struct(n: int) -> tuple:
    """``(unpack_from, size)`` for ``n`` big-endian float32s, cached."""
    got = _STRUCTS.get(n)
    if got is None:
        st = struct.Struct(f">{n}f")
        got = (st.unpack_from, st.size)
        if n <= 64:  # field runs and curves; long arrays vary too much to be worth keeping
            _STRUCTS[n] = got
    return got


def _same(v, default) -> bool:
    """``v`` equals ``default`` and may be left out (keeps ``-0.0``, which packs differently)."""
    if v is None or default is None:
        return v is default
    if v != default:
        return False
    return not (isinstance(v, float) and v == 0 and math.copysign(1.0, v) < 0)


def _to_end(node: dict, keys: tuple) -> None:
    """Move ``keys`` (those present) to the end of ``node``, in that order: the editor's
    JSON key order where it differs from the binary's field order."""
    for k in keys:
        if k in node:
            node[k] = node.pop(k)


def fields(s, node: dict, keys_defaults: tuple, order: tuple | None = None) -> None:
    """Consecutive float32 fields ``(key, default)``, read or written in one go.

    ``order``, indices into ``keys_defaults``, is the order in which a read puts them into
    ``node`` when the editor's JSON orders them differently from the binary.
    """
    n = len(keys_defaults)
    if s.reading:
        values = s.f32s(n)
        for i in order or range(n):
            key, d = keys_defaults[i]
            v = values[i]
            if v != d or (v == 0 and math.copysign(1.0, v) < 0):
                node[key] = v
    else:
        floats(s, [node.get(key, d) for key, d in keys_defaults], n, ", ".join(k for k, _ in keys_defaults))


def opt(s, node: dict, key: str, present: bool, default=0.0):
    """A float32 stored only when a flag says so (4.2)."""
    if not present:
        return default
    return fld(s, node, key, default)


def flag(node: dict, key: str, default, stored_default=0.0) -> bool:
    """Writer side of a 4.2 flag bit: set when the value differs from the binary default."""
    v = node.get(key, default)
    return not _same(v, stored_default) if isinstance(v, (int, float)) else v != stored_default


def floats(s, values, n: int, what: str = "floats") -> list:
    """``n`` float32 values in one go (bulk arrays: vertices, uvs, deform offsets)."""
    if s.reading:
        return s.f32s(n, what)
    try:
        s.raw(struct.pack(f">{n}f", *values))
    except struct.error:
        raise s.fail(f"{n} numbers for {what}") from None
    return values


def seq(s, items: list | None, fn, *args, what: str = "count") -> list:
    """A varint count followed by that many structures."""
    if s.reading:
        out = []
        for _ in range(s.count(what=what)):
            node = {}
            fn(s, node, *args)
            out.append(node)
        return out
    s.count(len(items))
    for node in items:
        fn(s, node, *args)
    return items


def _names(items) -> tuple[list, dict]:
    """:func:`~..symmetric.name_table` of the items' names."""
    return name_table([x.get("name") for x in items])


def fld_int(s, node: dict, key: str, default: int = 0) -> int:
    if s.reading:
        v = s.varint()
        _put(node, key, v, default)
        return v
    return s.varint(node.get(key, default))


def fld_u8(s, node: dict, key: str, default: int = 0) -> int:
    """A whole number stored in one byte (physics ``fps``)."""
    if s.reading:
        v = s.u8()
        _put(node, key, v, default)
        return v
    return s.u8(node.get(key, default), what=key)


def _flag_byte(s, node: dict, bits: tuple, value_flags: int = 0) -> int:
    """A flag byte: boolean keys at the low ``bits`` masks, plus precomputed ``value_flags``."""
    if s.reading:
        flags = s.u8()
        for mask, key, d in bits:
            _put(node, key, bool(flags & mask), d)
        return flags
    flags = value_flags
    for mask, key, d in bits:
        if node.get(key, d):
            flags |= mask
    s.u8(flags)
    return flags
